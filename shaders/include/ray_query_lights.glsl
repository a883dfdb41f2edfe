// Ray-query lights on the ray-query tier (seed 000 §5.2.5): the lighting compute pass finds a
// pixel's lights with one zero-length ray query against the lights' TLAS (light_boxes.glsl), as
// the decals are found, plus the unbounded lights every pixel loops over. Shadows come inline:
// each light that lights the point sends its shadow ray right there (a second ray query), so no
// per-pixel list and no shadow words are needed. Rays start from the surface lifted along its
// geometric normal and are culled when it faces away, as the shadow pass does with its
// reconstructed normal.
//
// Stochastic direct lighting (render/src/lights/sampling) samples here too, inline
// (light_draw.glsl): the first GpuLighting::sampled_lights_above lights a pixel finds get a ray
// each (none with `stochastic`, 32 with `auto`), and one light is drawn from the rest, whose
// unshadowed sum its one ray scales. Unlike a list, whose length is known before its walk, the
// count of found lights is known only at the walk's end: tracing the first lights as they come
// keeps `auto` exact where a pixel finds few (the same image as exhaustive) with one walk of the
// structure, and lowers the noise where it finds many, at a bounded cost (33 rays, and one to
// each sun). Suns get a ray each, as sampling pixels of a list give them.
#ifndef RAY_QUERY_LIGHTS_GLSL
#define RAY_QUERY_LIGHTS_GLSL

#extension GL_EXT_ray_query : require
#include "light_boxes.glsl"
#include "shadow_ray_query.glsl"
#include "direct_sampling.glsl"
#include "light_draw.glsl"

// The radiance of the light in `slot` at the surface, through its shadow ray when `shadows`
// (light_draw.glsl's `shadowed_by_ray`).
vec3 lit_by(GpuLight light, uint slot, SurfaceBrdf brdf, SurfaceInputs s, vec3 v, vec3 facing, bool shadows, bool cull) {
    vec3 c = shade_light(light, brdf, s.position, s.normal, v);
    return shadows ? shadowed_by_ray(light, slot, c, s.position, facing, cull) : c;
}

// The light in `slot`, found by the walk: shaded with its own shadow ray (`lit_by`) while the
// walk has rays to spare (`traced`, counted here), or when it is a sun traced apart; otherwise
// shaded unshadowed into `d` and offered to its draw.
vec3 enumerated_light(GpuLight light, uint slot, SurfaceBrdf brdf, SurfaceInputs s, vec3 v, vec3 facing, bool shadows, bool cull,
                      Suns suns, inout uint traced, inout LightDraw d) {
    bool sun = light.kind == LIGHT_DIRECTIONAL && sun_index(suns, slot) >= 0;
    if (!shadows || sun || traced < scene.lighting.lighting.sampled_lights_above) {
        traced += sun ? 0u : 1u;
        return lit_by(light, slot, brdf, s, v, facing, shadows, cull);
    }
    light_draw_offer(d, slot, shade_light(light, brdf, s.position, s.normal, v));
    return vec3(0.0);
}

vec3 enumerated_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found) {
    GpuLighting l = scene.lighting.lighting;
    found = 0u;
    vec3 color = vec3(0.0);
    if (l.light_tlas == 0ul) return color;
    bool shadows = (l.flags & SHADOWS_TRACED) != 0u;
    bool cull = (l.flags & SHADOW_RAY_CULLING) != 0u;
    vec3 facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
    Suns suns = sampling_suns();
    uint traced = 0u;
    LightDraw d = light_draw_start(s.position);
    UnboundedLightsRef unbounded = UnboundedLightsRef(l.unbounded_lights);
    uint unbounded_count = unbounded.count;
    for (uint k = 0u; k < unbounded_count; ++k) {
        uint slot = unbounded.slots[k];
        color += enumerated_light(scene.lights.lights[slot], slot, brdf, s, v, facing, shadows, cull, suns, traced, d);
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
        color += enumerated_light(light, slot, brdf, s, v, facing, shadows, cull, suns, traced, d);
    }
    // One shadow ray for the lights drawn from, to the drawn one.
    return color + light_draw_resolve(d, s.position, facing, cull);
}

#endif
