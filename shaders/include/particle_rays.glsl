// Particle collision with the scene's acceleration structure (render/src/particles), on both
// ray-tracing tiers: a step's segment is a ray, and its first hit (every surface opaque) is the
// contact, with the hit triangle's geometric normal turned against the step. Unlike the depth
// buffer, the structure holds what is off screen and what hides behind other surfaces.
//
// Most steps need no ray (depth_answers): one that starts and ends on screen in front of the
// surfaces the depth buffer shows there has nothing in its way (what is in front of those
// surfaces would be the surfaces), short of a feature thinner than a pixel; one that starts in
// front and ends on screen just behind the visible surface, crossing its plane at a point the
// depth buffer shows, crossed that surface, where the depth buffer's contact is (a fountain's
// particles bounce on the ground in view all the time).
// Only the others are traced: off screen, starting behind a visible surface, or ending far
// behind one (they may have passed behind it). 1,000,000 particles on the H200: 0.84 ms with a
// ray each, 0.37 ms tracing every step that went into a surface, and what the depth buffer
// leaves now costs little more than depth collision (docs/experiments/particles-gpu.md).
#ifndef PARTICLE_RAYS_GLSL
#define PARTICLE_RAYS_GLSL

#include "visibility.glsl"
#include "particle_depth.glsl"

// Whether point `b` is on screen and in front of (or as near as) the visible surface there.
bool in_front_of_depth(vec3 b) {
    GpuCamera cam = scene.camera.camera;
    vec4 clip = cam.view_proj * vec4(b, 1.0);
    if (clip.w <= 0.0) return false;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) return false;
    ivec2 px = clamp(ivec2(vec2(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * cam.viewport_size), ivec2(0), ivec2(cam.viewport_size) - 1);
    // Reverse-Z: nearer is larger; the sky's 0 is behind everything.
    return ndc.z > depth_at(px);
}

// Whether point `b` projects inside the view.
bool on_screen(vec3 b) {
    vec4 clip = scene.camera.camera.view_proj * vec4(b, 1.0);
    return clip.w > 0.0 && all(lessThanEqual(abs(clip.xy / clip.w), vec2(1.0)));
}

// Whether point `x` lies on the surface the depth buffer shows at its pixel: its distance to
// the camera within 2 % (and a centimetre) of the surface's.
bool on_visible_surface(vec3 x) {
    GpuCamera cam = scene.camera.camera;
    vec4 clip = cam.view_proj * vec4(x, 1.0);
    if (clip.w <= 0.0) return false;
    vec2 ndc = clip.xy / clip.w;
    if (any(greaterThan(abs(ndc), vec2(1.0)))) return false;
    ivec2 px = clamp(ivec2(vec2(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * cam.viewport_size), ivec2(0), ivec2(cam.viewport_size) - 1);
    float depth = depth_at(px);
    if (depth <= 0.0) return false;
    float d = distance(cam.position, x), surface = distance(cam.position, world_from_depth(vec2(px), depth));
    return abs(d - surface) <= 0.02 * surface + 0.01;
}

// Whether the depth buffer answers the step from `a` to `b` (false: trace it), and then whether
// it touched a surface (`contact`), where and the surface's normal: the step starts on screen in
// front of the visible surface and either stays in front of it or ends on screen behind it by
// less than a thickness (depth_contact).
bool depth_answers(vec3 a, vec3 b, out bool contact, out vec3 hit, out vec3 n) {
    hit = b;
    n = vec3(0.0, 1.0, 0.0);
    contact = false;
    if (!in_front_of_depth(a)) return false;
    if (in_front_of_depth(b)) return true;
    if (!on_screen(b)) return false;
    if (!depth_contact(a, b, max(0.1, 2.0 * distance(a, b)), hit, n)) return false;
    // At a silhouette the step may have passed behind the surface rather than into it (beside
    // a pole, to behind it): the depth buffer answers only a step that crosses the surface's
    // plane from its front to its back at a point the depth buffer shows; the rest is traced.
    contact = dot(a - hit, n) > 0.0 && dot(b - hit, n) <= 0.0 && on_visible_surface(hit);
    return contact;
}

// The contact on triangle `triangle` of instance slot `instance`, `t` along the step from `a`
// (unit direction `dir`).
void ray_contact(uint instance, uint triangle, vec3 a, vec3 dir, float t, out vec3 hit, out vec3 n) {
    InstanceTriangle tri = instance_triangle(instance, triangle);
    n = safe_normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0), vec3(0.0, 1.0, 0.0));
    if (dot(n, dir) > 0.0) n = -n;
    hit = a + dir * t;
}

#endif
