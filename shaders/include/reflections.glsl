// Ray-traced reflections in which decals appear (render/src/reflections; seed 000 §2.4 lists
// ray-query reflections among its renderer's options and shows decals under them in Fig. 2.4;
// its §6 proposes ray-query decals in real-time ray tracing). A reflection ray is a ray query
// against the scene TLAS; the surface it hits is rebuilt bindlessly as the visibility buffer
// rebuilds its pixels (visibility.glsl's hit_surface, visbuffer_surface.glsl's surface_inputs),
// and shaded with the decals there, found by the same zero-length ray in the decal TLAS as on
// screen (shading.glsl's traced_decals), and the lights there, found in the lights' TLAS with
// their shadow rays (ray_query_lights.glsl). Screen-space and clustered decals cannot do this:
// the hit point is usually somewhere the camera does not see.
//
// Along the ray, alpha-masked surfaces are alpha-tested (alpha_mask.glsl) and blended ones
// (glass) do not stop it: up to REFLECTION_GLASS panes in front of the hit are shaded and
// blended over it back to front by their opacity, as the transparency passes draw glass on
// screen (back faces only on double-sided materials). A miss sees the clear colour (the sky).
#ifndef REFLECTIONS_GLSL
#define REFLECTIONS_GLSL

#define DECALS_AT_HITS
#extension GL_EXT_ray_query : require
#include "visbuffer_surface.glsl"
#include "ray_query_lights.glsl"
#include "alpha_mask.glsl"
#include "brdf.glsl"

// GpuLighting::reflection_stats (REFLECTION_STATS words).
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ReflectionStatsRef { uint words[]; };
const uint REFLECTION_STAT_PIXELS = 0u;          // pixels that reflect
const uint REFLECTION_STAT_RAYS = 1u;            // reflection rays traced
const uint REFLECTION_STAT_HITS = 2u;            // rays that hit geometry
const uint REFLECTION_STAT_DECALS_TESTED = 3u;   // decal candidates tested at hit points
const uint REFLECTION_STAT_LIGHTS = 4u;          // lights found at hit points
const uint REFLECTION_STAT_GLASS = 5u;           // rays that crossed glass

// Panes of glass a reflection ray remembers (nearer candidates past this many are ignored).
const uint REFLECTION_GLASS = 4u;
const float REFLECTION_MAX_DISTANCE = 1.0e4;
// Roughness below which a surface is a mirror: its ray is exact and not filtered.
const float REFLECTION_MIRROR = 0.05;

struct ReflectionRay {
    vec3 radiance;
    float distance;       // to the hit (REFLECTION_MAX_DISTANCE on a miss)
    bool hit;
    bool glass;           // crossed a blended surface
    uint decals_tested;   // at the hit point (and the glass pane's)
    uint lights_found;
};

// A hit surface's radiance towards `v`: its decals, the ambient term, emission and its lights
// with their shadow rays.
vec3 shade_hit(SurfaceInputs s, vec3 v, inout ReflectionRay r) {
    r.decals_tested += traced_decals(s);
    SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
    vec3 color = s.emissive + scene.camera.camera.ambient * (brdf.diffuse_color + brdf.f0) * s.occlusion;
    uint found;
    color += enumerated_lights(brdf, s, v, found);
    r.lights_found += found;
    return color;
}

// The cone's width `t` metres along a reflection ray that left a surface where it was `width0`
// across, spreading by `spread` radians.
float cone_width(float width0, float spread, float t) {
    return width0 + spread * t;
}

// Traces the reflection ray origin + t·dir and shades what it sees.
ReflectionRay trace_reflection(vec3 origin, vec3 dir, float width0, float spread) {
    ReflectionRay r = ReflectionRay(vec3(0.0), REFLECTION_MAX_DISTANCE, false, false, 0u, 0u);
    rayQueryEXT q;
    rayQueryInitializeEXT(q, accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsNoneEXT, 0xFF, origin, 0.0, dir,
                          REFLECTION_MAX_DISTANCE);
    float glass_t[REFLECTION_GLASS];
    uvec2 glass_ids[REFLECTION_GLASS];
    vec2 glass_bary[REFLECTION_GLASS];
    uint panes = 0u;
    // Only masked and blended instances are non-opaque in the scene TLAS, so only they come here.
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) != gl_RayQueryCandidateIntersectionTriangleEXT) continue;
        uint instance = rayQueryGetIntersectionInstanceCustomIndexEXT(q, false);
        uint primitive = rayQueryGetIntersectionPrimitiveIndexEXT(q, false);
        vec2 bary = rayQueryGetIntersectionBarycentricsEXT(q, false);
        GpuInstance inst = scene.instances.instances[instance];
        GpuMaterial m = scene.materials.materials[inst.material];
        if ((m.flags & MATERIAL_BLEND) != 0u) {
            // Glass as the transparency passes draw it: back faces only when double-sided.
            InstanceTriangle t = instance_triangle(instance, primitive);
            bool front = dot(cross(t.p1 - t.p0, t.p2 - t.p0), dir) < 0.0;
            if (panes < REFLECTION_GLASS && (front || (m.flags & MATERIAL_DOUBLE_SIDED) != 0u)) {
                glass_t[panes] = rayQueryGetIntersectionTEXT(q, false);
                glass_ids[panes] = uvec2(instance, primitive);
                glass_bary[panes] = bary;
                ++panes;
            }
            continue;
        }
        if ((m.flags & MATERIAL_ALPHA_MASK) == 0u || hit_base_color(inst, m, primitive, bary).a >= m.alpha_cutoff) {
            rayQueryConfirmIntersectionEXT(q);
        }
    }
    if (rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionTriangleEXT) {
        r.hit = true;
        r.distance = rayQueryGetIntersectionTEXT(q, true);
        VisibleSurface v = hit_surface(rayQueryGetIntersectionInstanceCustomIndexEXT(q, true), rayQueryGetIntersectionPrimitiveIndexEXT(q, true),
                                       rayQueryGetIntersectionBarycentricsEXT(q, true), dir, cone_width(width0, spread, r.distance));
        r.radiance = shade_hit(surface_inputs(v), -dir, r);
    } else {
        r.radiance = scene.lighting.lighting.clear_color.rgb;
    }
    // Glass in front of the hit, blended over it back to front as the transparency passes blend
    // it on screen: each pane shaded, over what lies behind by its opacity.
    for (uint done = 0u; done < panes; ++done) {
        uint far = REFLECTION_GLASS;
        for (uint i = 0u; i < panes; ++i) {
            if (glass_t[i] < r.distance && (far == REFLECTION_GLASS || glass_t[i] > glass_t[far])) far = i;
        }
        if (far == REFLECTION_GLASS) break;
        r.glass = true;
        VisibleSurface v = hit_surface(glass_ids[far].x, glass_ids[far].y, glass_bary[far], dir, cone_width(width0, spread, glass_t[far]));
        float opacity = clamp(sample_material(v.material, v.uv, v.duvdx, v.duvdy).base.a, 0.0, 1.0);
        r.radiance = mix(r.radiance, shade_hit(surface_inputs(v), -dir, r), opacity);
        glass_t[far] = REFLECTION_MAX_DISTANCE;   // done
    }
    return r;
}

// A hash of a pixel to two numbers in [0, 1) (a fixed pattern: the spatial filter averages it
// out, and still frames stay still).
vec2 pixel_noise(uvec2 px) {
    uvec2 v = px * uvec2(1664525u, 1013904223u);
    v.x += v.y * 1664525u;
    v.y += v.x * 1664525u;
    v ^= v >> 16u;
    v.x += v.y * 1664525u;
    v.y += v.x * 1664525u;
    v ^= v >> 16u;
    return vec2(v) * (1.0 / 4294967296.0);
}

// The direction a surface with shading normal `n`, viewed along `v` (towards the eye), reflects
// to: the mirror direction below REFLECTION_MIRROR, else one drawn from the GGX lobe.
vec3 reflection_direction(vec3 n, vec3 v, float roughness, vec2 u) {
    if (roughness < REFLECTION_MIRROR) return reflect(-v, n);
    vec3 t = normalize(abs(n.z) < 0.999 ? cross(vec3(0.0, 0.0, 1.0), n) : cross(vec3(1.0, 0.0, 0.0), n));
    vec3 b = cross(n, t);
    vec3 local_v = vec3(dot(v, t), dot(v, b), dot(v, n));
    vec3 h = sample_ggx_vndf(local_v, roughness * roughness, u);
    vec3 l = reflect(-v, t * h.x + b * h.y + n * h.z);
    return dot(l, n) > 1e-3 ? l : reflect(-v, n);   // below the surface: take the mirror direction
}

#endif
