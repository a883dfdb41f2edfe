// Ray-query lights on the ray-query tier (seed 000 §5.2.5): the lighting compute pass finds a
// pixel's lights with one zero-length ray query against the lights' TLAS (light_boxes.glsl), as
// the decals are found, plus the unbounded lights every pixel loops over. Shadows come inline:
// each light that lights the point sends its shadow ray right there (a second ray query), so no
// per-pixel list and no shadow words are needed. Rays start from the surface lifted along its
// geometric normal and are culled when it faces away, as the shadow pass does with its
// reconstructed normal.
//
// Stochastic direct lighting (render/src/lights/sampling) samples here too, inline: the first
// GpuLighting::sampled_lights_above lights a pixel finds get a ray each (none with `stochastic`,
// 32 with `auto`), and the rest are drawn from: each is shaded unshadowed into a sum, one of them
// is drawn in proportion to the luminance of that light (weighted reservoir sampling, as
// direct_sampling.glsl draws from a list; here the material is at hand, so the draw follows the
// whole BRDF, specular lobe included), and the sum is multiplied by what its one shadow ray lets
// through (the ratio estimator of Heitz et al. 2018, a pixel's own: no denoiser runs between the
// ray and shading). What is unshadowed stays exact; what is not is right on average, noise that
// temporal anti-aliasing averages (the draws change with its frame count, and stay put without
// it). Unlike a list, whose length is known before its walk, the count of found lights is known
// only at the walk's end: tracing the first lights as they come keeps `auto` exact where a pixel
// finds few (the same image as exhaustive) with one walk of the structure, and lowers the
// noise where it finds many, at a bounded cost (33 rays, and one to each sun). Suns get a ray
// each, as sampling pixels of a list give them.
#ifndef RAY_QUERY_LIGHTS_GLSL
#define RAY_QUERY_LIGHTS_GLSL

#extension GL_EXT_ray_query : require
#include "light_boxes.glsl"
#include "shadow_ray_query.glsl"
#include "direct_sampling.glsl"

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

// The lights a walk draws from (after the first GpuLighting::sampled_lights_above): their
// unshadowed light summed, their luminances summed, and the slot drawn in proportion so far.
struct EnumeratedDraw {
    vec3 unshadowed;
    float total;
    uint slot;
    uint seed;
};

// The light in `slot`, found by the walk: shaded with its own shadow ray (`lit_by`) while the
// walk has rays to spare (`traced`, counted here), or when it is a sun traced apart; otherwise
// shaded unshadowed into `d` and offered to its draw.
vec3 enumerated_light(GpuLight light, uint slot, SurfaceBrdf brdf, SurfaceInputs s, vec3 v, vec3 facing, bool shadows, bool cull,
                      Suns suns, inout uint traced, inout EnumeratedDraw d) {
    bool sun = light.kind == LIGHT_DIRECTIONAL && sun_index(suns, slot) >= 0;
    if (!shadows || sun || traced < scene.lighting.lighting.sampled_lights_above) {
        traced += sun ? 0u : 1u;
        return lit_by(light, slot, brdf, s, v, facing, shadows, cull);
    }
    vec3 c = shade_light(light, brdf, s.position, s.normal, v);
    float w = luminance(c);
    if (w > 0.0) {
        d.unshadowed += c;
        d.total += w;
        if (random01(d.seed) * d.total <= w) d.slot = slot;
    }
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
    // The draw's numbers: a hash of the point and temporal anti-aliasing's frame count, apart
    // from the points on lights (shadow_sample_at).
    uvec3 bits = floatBitsToUint(s.position);
    EnumeratedDraw d = EnumeratedDraw(vec3(0.0), 0.0, NO_SLOT,
                                      pcg_hash(bits.x ^ pcg_hash(bits.y ^ pcg_hash(bits.z ^ 0x68E31DA4u)) ^ pcg_hash(~scene.camera.camera.taa_frame)));
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
    // One shadow ray for the lights drawn from, to the drawn one: the share it lets through
    // scales their unshadowed sum.
    if (d.slot != NO_SLOT) {
        GpuLight light = scene.lights.lights[d.slot];
        vec3 dir;
        float tmax;
        if (shadow_ray_sampled(light, s.position, shadow_sample_at(s.position, d.slot), dir, tmax) && !(cull && dot(facing, dir) <= 0.0)) {
            color += d.unshadowed * shadow_ray_transmittance(shadow_origin(s.position, facing), dir, 1e-3, tmax);
        }
    }
    return color;
}

#endif
