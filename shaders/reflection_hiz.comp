#version 460
// Screen-space reflections' depth pyramid (render/src/reflections), HIZ_LEVELS_PER_DISPATCH
// levels from `scene.texture_index` on: each texel the nearest (largest, reverse Z) of the 2×2
// texels below it, clamped at the edges; level 0 reads the depth target. The rays skip whole
// texels they pass in front of (reflections.glsl, REFLECTION_SCREEN_SPACE).
#include "scene.glsl"
#include "depth_pyramid_build.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    uvec2 viewport = uvec2(scene.camera.camera.viewport_size);
    pyramid_levels(HizRef(scene.lighting.lighting.reflection_hiz), viewport, scene.texture_index, true);
}
