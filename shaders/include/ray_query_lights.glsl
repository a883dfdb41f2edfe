// Ray-query lights on the ray-query tier (seed 000 §5.2.5): the lighting compute pass finds a
// pixel's lights with one zero-length ray query against the lights' TLAS (light_boxes.glsl), as
// the decals are found, plus the unbounded lights every pixel loops over. Shadows come inline:
// each light that lights the point sends its shadow ray right there (a second ray query), so no
// per-pixel list and no shadow words are needed. Rays start from the surface lifted along its
// geometric normal and are culled when it faces away, as the shadow pass does with its
// reconstructed normal.
#ifndef RAY_QUERY_LIGHTS_GLSL
#define RAY_QUERY_LIGHTS_GLSL

#extension GL_EXT_ray_query : require
#include "light_boxes.glsl"
#include "shadow_ray_query.glsl"

// The radiance of the light in `slot` at the surface, zero when its shadow ray is blocked or
// culled, filtered by the glass it crossed. The ray aims at a point of the light's shape (soft
// shadows where it has a size, as the shadow pass does), chosen by a hash of the surface point.
vec3 lit_by(GpuLight light, uint slot, SurfaceBrdf brdf, SurfaceInputs s, vec3 v, vec3 facing, bool shadows, bool cull) {
    vec3 c = shade_light(light, brdf, s.position, s.normal, v);
    if (!shadows || all(equal(c, vec3(0.0)))) return c;
    vec3 dir;
    float tmax;
    if (!shadow_ray_sampled(light, s.position, shadow_sample_at(s.position, slot), dir, tmax)) return vec3(0.0);
    if (cull && dot(facing, dir) <= 0.0) return vec3(0.0);
    return c * shadow_ray_transmittance(shadow_origin(s.position, facing), dir, 1e-3, tmax);
}

vec3 enumerated_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found) {
    GpuLighting l = scene.lighting.lighting;
    found = 0u;
    vec3 color = vec3(0.0);
    if (l.light_tlas == 0ul) return color;
    bool shadows = (l.flags & SHADOWS_TRACED) != 0u;
    bool cull = (l.flags & SHADOW_RAY_CULLING) != 0u;
    vec3 facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
    UnboundedLightsRef unbounded = UnboundedLightsRef(l.unbounded_lights);
    uint unbounded_count = unbounded.count;
    for (uint k = 0u; k < unbounded_count; ++k) {
        uint slot = unbounded.slots[k];
        color += lit_by(scene.lights.lights[slot], slot, brdf, s, v, facing, shadows, cull);
    }
    found = unbounded_count;
    rayQueryEXT query;
    rayQueryInitializeEXT(query, accelerationStructureEXT(l.light_tlas), gl_RayFlagsSkipClosestHitShaderEXT | gl_RayFlagsOpaqueEXT, 0xFF,
                          s.position, 0.0, vec3(1.0, 0.0, 0.0), 0.0);
    while (rayQueryProceedEXT(query)) {
        uint slot = uint(rayQueryGetIntersectionPrimitiveIndexEXT(query, false));
        GpuLight light = scene.lights.lights[slot];
        if (!light_box_holds(light, s.position)) continue;
        ++found;
        color += lit_by(light, slot, brdf, s, v, facing, shadows, cull);
    }
    return color;
}

#endif
