// Normals reconstructed from depth (seed 001 §4.3.1), for the shadow pass, which works from
// depth alone so that it serves every pipeline.
// - Naive (3 taps): the cross product of the differences to the next pixel across and down.
//   Across a depth edge the neighbour lies on another surface and the normal is wrong.
// - Improved (5 taps per axis, Yuwen Wu's method as the seed uses it): the two pixels on each
//   side are extrapolated to the centre; the side whose extrapolation lands closer to the
//   centre's depth is on the centre's surface, and its difference is used. Reverse-Z depth is
//   proportional to 1/view distance, which is affine across a plane in screen space, so the
//   extrapolation is exact on planes and comparing raw depths is right.
// Both normals are turned to face the camera.
#ifndef DEPTH_NORMALS_GLSL
#define DEPTH_NORMALS_GLSL

#include "depth.glsl"

// The depth normals are rebuilt from: the depth target, or (GLASS_LAYER: the shadow pass over
// the nearest blended surfaces, shadow_pass.glsl) the transparent depth.
#ifdef GLASS_LAYER
#define NORMALS_DEPTH transparent_depth
#else
#define NORMALS_DEPTH depth_target
#endif

bool pixel_inside(ivec2 px) {
    return all(greaterThanEqual(px, ivec2(0))) && all(lessThan(px, ivec2(scene.camera.camera.viewport_size)));
}

vec3 facing_camera(vec3 n, vec3 p) {
    return dot(n, scene.camera.camera.position - p) < 0.0 ? -n : n;
}

// World-space step to the next pixel along `step`, from the nearest neighbours only.
vec3 naive_difference(ivec2 px, vec3 p, ivec2 step) {
    ivec2 q = pixel_inside(px + step) ? px + step : px - step;
    float d = texelFetch(NORMALS_DEPTH, q, 0).r;
    if (d <= 0.0) return vec3(0.0);
    return (world_from_depth(vec2(q), d) - p) * float(q.x - px.x + q.y - px.y);
}

vec3 normal_from_depth_naive(ivec2 px, float depth, vec3 p) {
    vec3 dx = naive_difference(px, p, ivec2(1, 0));
    vec3 dy = naive_difference(px, p, ivec2(0, row_step()));
    return facing_camera(safe_normalize(cross(dy, dx), vec3(0.0, 1.0, 0.0)), p);
}

float depth_or_sky(ivec2 px) {
    return pixel_inside(px) ? texelFetch(NORMALS_DEPTH, px, 0).r : 0.0;
}

// World-space step to the next pixel along `step`, from the side on the centre's surface.
vec3 improved_difference(ivec2 px, float c, vec3 p, ivec2 step) {
    float a = depth_or_sky(px - 2 * step), b = depth_or_sky(px - step);
    float d = depth_or_sky(px + step), e = depth_or_sky(px + 2 * step);
    // A missing or sky neighbour is never on the surface; with one tap of a side left, that
    // side's extrapolation is its own depth.
    float left = b > 0.0 ? abs((a > 0.0 ? 2.0 * b - a : b) - c) : 1.0 / 0.0;
    float right = d > 0.0 ? abs((e > 0.0 ? 2.0 * d - e : d) - c) : 1.0 / 0.0;
    if (left < right) return p - world_from_depth(vec2(px - step), b);
    if (d > 0.0) return world_from_depth(vec2(px + step), d) - p;
    return vec3(0.0);
}

vec3 normal_from_depth_improved(ivec2 px, float depth, vec3 p) {
    vec3 dx = improved_difference(px, depth, p, ivec2(1, 0));
    vec3 dy = improved_difference(px, depth, p, ivec2(0, row_step()));
    return facing_camera(safe_normalize(cross(dy, dx), vec3(0.0, 1.0, 0.0)), p);
}

#endif
