// Particle collision with the scene's acceleration structure (render/src/particles), on both
// ray-tracing tiers: a step's segment is a ray, and its first hit (every surface opaque) is the
// contact, with the hit triangle's geometric normal turned against the step. Unlike the depth
// buffer, the structure holds what is off screen and what hides behind other surfaces.
#ifndef PARTICLE_RAYS_GLSL
#define PARTICLE_RAYS_GLSL

#include "visibility.glsl"

// The contact on triangle `triangle` of instance slot `instance`, `t` along the step from `a`
// (unit direction `dir`).
void ray_contact(uint instance, uint triangle, vec3 a, vec3 dir, float t, out vec3 hit, out vec3 n) {
    InstanceTriangle tri = instance_triangle(instance, triangle);
    n = safe_normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0), vec3(0.0, 1.0, 0.0));
    if (dot(n, dir) > 0.0) n = -n;
    hit = a + dir * t;
}

#endif
