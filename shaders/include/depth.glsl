// Reverse-Z depth to world position (seed 001 alg. 4.1, with its fma form of the NDC mapping),
// and world-position derivatives for full-screen passes. A full-screen pass has no surface to
// differentiate, and quad derivatives of reconstructed positions break at depth edges (the
// artefacts seed 000 §4.1.3 reports for deferred decals); instead each pixel picks, per axis,
// the neighbour whose depth is closer to its own, so the difference stays on one surface.
#ifndef DEPTH_GLSL
#define DEPTH_GLSL

#include "scene.glsl"
#include "normals.glsl"

// `px` is the pixel; the viewport is flipped (render/src/pipeline.rs), so row 0 is NDC y = +1.
vec3 world_from_depth(vec2 px, float depth) {
    GpuCamera cam = scene.camera.camera;
    vec2 ndc = vec2(fma((px.x + 0.5) * cam.inv_viewport_size.x, 2.0, -1.0),
                    fma((px.y + 0.5) * cam.inv_viewport_size.y, -2.0, 1.0));
    vec4 w = cam.inv_view_proj * vec4(ndc, depth, 1.0);
    return w.xyz / w.w;
}

// Rows between vertically neighbouring samples of one surface: 2 when the deferred G-buffer
// interlaces transparency (odd rows may hold glass, even rows what is behind it), else 1.
int row_step() {
    return (scene.lighting.lighting.flags & INTERLACED) != 0u ? 2 : 1;
}

float depth_at(ivec2 px) {
    ivec2 size = ivec2(scene.camera.camera.viewport_size);
    return texelFetch(depth_target, clamp(px, ivec2(0), size - 1), 0).r;
}

// World position of the pixel one step along `dir`, preferring the side on the same surface;
// a side past the image's edge or on the sky is never used.
vec3 neighbour_difference(ivec2 px, float depth, vec3 p, ivec2 dir) {
    ivec2 size = ivec2(scene.camera.camera.viewport_size);
    float d_plus = all(lessThan(px + dir, size)) ? depth_at(px + dir) : 0.0;
    float d_minus = all(greaterThanEqual(px - dir, ivec2(0))) ? depth_at(px - dir) : 0.0;
    bool use_plus = d_plus > 0.0 && (d_minus <= 0.0 || abs(d_plus - depth) <= abs(d_minus - depth));
    if (use_plus) return world_from_depth(vec2(px + dir), d_plus) - p;
    if (d_minus > 0.0) return p - world_from_depth(vec2(px - dir), d_minus);
    return vec3(0.0);
}

void world_derivatives(ivec2 px, float depth, vec3 p, out vec3 dpdx, out vec3 dpdy) {
    dpdx = neighbour_difference(px, depth, p, ivec2(1, 0));
    int rows = row_step();
    dpdy = neighbour_difference(px, depth, p, ivec2(0, rows)) / float(rows);
}

#endif
