// Particle collision with the depth buffer (render/src/particles): every tier, and on the
// ray-tracing tiers for the steps the depth buffer answers (particle_rays.glsl).
#ifndef PARTICLE_DEPTH_GLSL
#define PARTICLE_DEPTH_GLSL

#include "depth_normals.glsl"

// Where the step from `a` to `b` went behind the surface the depth buffer shows, if it did:
// the point where it crossed the surface's plane and the surface's normal. A step ending
// more than `thickness` metres behind the surface passed behind something, not into it.
bool depth_contact(vec3 a, vec3 b, float thickness, out vec3 hit, out vec3 n) {
    hit = b;
    n = vec3(0.0, 1.0, 0.0);
    GpuCamera cam = scene.camera.camera;
    vec4 clip = cam.view_proj * vec4(b, 1.0);
    if (clip.w <= 0.0) return false;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) return false;
    // The viewport is flipped: row 0 is NDC y = +1.
    ivec2 px = ivec2(vec2(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * cam.viewport_size);
    px = clamp(px, ivec2(0), ivec2(cam.viewport_size) - 1);
    float depth = depth_at(px);
    // Sky, or in front of the surface (reverse-Z: nearer is larger).
    if (depth <= 0.0 || ndc.z >= depth) return false;
    vec3 s = world_from_depth(vec2(px), depth);
    float behind = distance(cam.position, b) - distance(cam.position, s);
    if (behind > thickness) return false;
    n = normal_from_depth_improved(px, depth, s);
    float da = dot(a - s, n), db = dot(b - s, n);
    float t = da > db ? clamp(da / (da - db), 0.0, 1.0) : 1.0;
    hit = mix(a, b, t);
    // On the plane's front side, whatever rounding did.
    hit += n * max(0.0, -dot(hit - s, n));
    return true;
}

#endif
