#version 460
// The depth pyramid (render/src/culling), HIZ_LEVELS_PER_DISPATCH levels from `cull.level` on:
// each texel the farthest (smallest, reverse Z) of the 2×2 texels below it, clamped at the
// edges; level 0 reads the depth target.
#include "culling.glsl"
#include "depth_pyramid_build.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    GpuCullParams p = cull_params();
    pyramid_levels(HizRef(p.hiz), uvec2(p.viewport), cull.level, false);
}
