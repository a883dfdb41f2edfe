// Ray-query lights on the ray-tracing-pipeline tier (the lent GPUs have no ray queries): the
// lighting pass is a ray-generation shader (deferred_lighting.rgen, visbuffer_shade.rgen) that
// sends one zero-length ray per pixel against the lights' TLAS (light_boxes.glsl). The
// intersection shader (light_rays.rint) runs the exact range test on each box holding the
// ray's origin; the any-hit shader (light_rays.rahit) adds the light's radiance to the payload
// and ignores the hit, so traversal goes on to every other light there. Radiance adds up in any
// order, so the arbitrary order of any-hit invocations changes nothing but rounding.
//
// Shadows: an any-hit shader cannot trace a ray, so it cannot give each light found its shadow
// ray as the ray-query tier does. With SAMPLED_LIGHTS (the lighting pass's pipeline for frames
// with shadows) it draws instead (light_draw.glsl): each light found is shaded unshadowed into
// the payload's sum and offered to a draw in proportion to its light, and the ray-generation
// shader then traces one shadow ray, to the drawn light, whose share scales the sum; the
// unbounded lights (the suns among them) get a ray each there. So on this tier ray-query lights'
// shadows are always sampled, whatever `--direct-light` asks ("direct_light":"stochastic" as
// applied): a ray each would need every light found kept in the payload.
#ifndef RAY_PIPELINE_LIGHTS_GLSL
#define RAY_PIPELINE_LIGHTS_GLSL

#include "color.glsl"
#include "lighting.glsl"
#include "light_boxes.glsl"
#ifdef SAMPLED_LIGHTS
#ifndef LIGHT_RAYGEN
#define LIGHT_DRAW_OFFER_ONLY
#endif
#include "light_draw.glsl"
#endif

// The surface travels with the ray (its position is the ray's origin); the radiance and the
// number of lights found come back. With SHADOWED_LIGHTS (the reflection rays' hit points,
// reflections.glsl) the LIGHT_SHADOW_SLOTS lights that contribute most are kept apart instead,
// for the ray-generation shader to trace their shadow rays: the any-hit shader cannot.
const uint LIGHT_SHADOW_SLOTS = 4u;
struct LightPayload {
    SurfaceBrdf brdf;
    vec3 normal;
    vec3 view;
    vec3 color;
    uint found;
#ifdef SHADOWED_LIGHTS
    uint slots[LIGHT_SHADOW_SLOTS];    // light slots (NO_SHADOWED_LIGHT: none)
    vec3 slot_color[LIGHT_SHADOW_SLOTS];
#endif
#ifdef SAMPLED_LIGHTS
    LightDraw draw;                    // the lights found, drawn from (`color` stays empty)
#endif
};
const uint NO_SHADOWED_LIGHT = 0xFFFFFFFFu;

#ifdef SHADOWED_LIGHTS
float light_strength(vec3 c) {
    return luminance(c);
}

// Adds light `slot`'s radiance `c` to the payload: kept apart if it is among the strongest so
// far (the weakest kept one then joins the unshadowed sum), else added unshadowed.
void keep_light(inout LightPayload p, uint slot, vec3 c) {
    uint weakest = 0u;
    for (uint i = 1u; i < LIGHT_SHADOW_SLOTS; ++i) {
        if (light_strength(p.slot_color[i]) < light_strength(p.slot_color[weakest])) weakest = i;
    }
    if (light_strength(c) <= light_strength(p.slot_color[weakest])) {
        p.color += c;
        return;
    }
    p.color += p.slot_color[weakest];
    p.slots[weakest] = slot;
    p.slot_color[weakest] = c;
}
#endif

#ifdef LIGHT_RAYGEN
// A ray-generation shader that traces other rays too (reflections.glsl) moves the payload and
// the hit group and miss shader these lights' rays use.
#ifndef LIGHT_PAYLOAD_LOCATION
#define LIGHT_PAYLOAD_LOCATION 0
#define LIGHT_SBT_OFFSET 0
#endif
layout(location = LIGHT_PAYLOAD_LOCATION) rayPayloadEXT LightPayload light_payload;

#ifdef SAMPLED_LIGHTS
// The lighting pass's shadow rays: the shadow pass's any-hit and miss shaders (shadows.rahit,
// shadows.rmiss) at hit group and miss index 1, with their payload at location 1.
#define SHADOW_SBT_INDEX 1
#define SHADOW_PAYLOAD_LOCATION 1
#include "shadow_ray_pipeline.glsl"
#endif

vec3 enumerated_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found) {
    GpuLighting l = scene.lighting.lighting;
    found = 0u;
    if (l.light_tlas == 0ul) return vec3(0.0);
    light_payload.brdf = brdf;
    light_payload.normal = s.normal;
    light_payload.view = v;
    light_payload.color = vec3(0.0);
    light_payload.found = 0u;
#ifdef SAMPLED_LIGHTS
    light_payload.draw = light_draw_start(s.position);
    bool cull = (l.flags & SHADOW_RAY_CULLING) != 0u;
    vec3 facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
#endif
    UnboundedLightsRef unbounded = UnboundedLightsRef(l.unbounded_lights);
    uint unbounded_count = unbounded.count;
    vec3 color = vec3(0.0);
    for (uint k = 0u; k < unbounded_count; ++k) {
        uint slot = unbounded.slots[k];
        GpuLight light = scene.lights.lights[slot];
        vec3 c = shade_light(light, brdf, s.position, s.normal, v);
#ifdef SAMPLED_LIGHTS
        c = shadowed_by_ray(light, slot, c, s.position, facing, cull);
#endif
        color += c;
    }
    traceRayEXT(accelerationStructureEXT(l.light_tlas), gl_RayFlagsNoOpaqueEXT | gl_RayFlagsSkipClosestHitShaderEXT, 0xFF, LIGHT_SBT_OFFSET, 0,
                LIGHT_SBT_OFFSET, s.position, 0.0, vec3(1.0, 0.0, 0.0), 0.0, LIGHT_PAYLOAD_LOCATION);
    found = unbounded_count + light_payload.found;
#ifdef SAMPLED_LIGHTS
    color += light_draw_resolve(light_payload.draw, s.position, facing, cull);
#endif
    return color + light_payload.color;
}
#endif

#endif
