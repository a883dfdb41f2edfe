#version 460
// One level of the depth pyramid (render/src/culling): each texel the farthest (smallest,
// reverse Z) of the 2×2 texels below it, clamped at the edges; level 0 reads the depth target.
#include "culling.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    GpuCullParams p = cull_params();
    uvec2 viewport = uvec2(p.viewport);
    uint level = cull.level;
    uvec2 size = hiz_size(viewport, level);
    uvec2 t = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(t, size))) return;
    HizRef h = HizRef(p.hiz);
    float d = pyramid_texel(h, viewport, level, t, false);
    h.depth[hiz_offset(viewport, level) + t.y * size.x + t.x] = d;
}
