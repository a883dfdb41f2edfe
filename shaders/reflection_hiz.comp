#version 460
// One level (`scene.texture_index`) of screen-space reflections' depth pyramid
// (render/src/reflections): each texel the nearest (largest, reverse Z) of the 2×2 texels below
// it, clamped at the edges; level 0 reads the depth target. The rays skip whole texels they pass
// in front of (reflections.glsl, REFLECTION_SCREEN_SPACE).
#include "scene.glsl"
#include "depth_pyramid.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    uvec2 viewport = uvec2(scene.camera.camera.viewport_size);
    uint level = scene.texture_index;
    uvec2 size = hiz_size(viewport, level);
    uvec2 t = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(t, size))) return;
    HizRef h = HizRef(scene.lighting.lighting.reflection_hiz);
    float d = pyramid_texel(h, viewport, level, t, true);
    h.depth[hiz_offset(viewport, level) + t.y * size.x + t.x] = d;
}
