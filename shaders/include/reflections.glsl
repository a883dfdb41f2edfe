// Ray-traced reflections in which decals appear (render/src/reflections; seed 000 §2.4 lists
// ray-query reflections among its renderer's options and shows decals under them in Fig. 2.4;
// its §6 proposes ray-query decals in real-time ray tracing). A reflection ray is traced against
// the scene TLAS; the surface it hits is rebuilt bindlessly as the visibility buffer rebuilds its
// pixels (visibility.glsl's hit_surface, visbuffer_surface.glsl's surface_inputs), and shaded
// with the decals there, found by a zero-length ray in the decal TLAS as on screen, and the
// lights there, found in the lights' TLAS. Screen-space and clustered decals cannot do this: the
// hit point is usually somewhere the camera does not see.
//
// Two formulations of the same rays, as for decals and lights:
// - REFLECTION_RAY_QUERY (reflections.comp, the ray-query tier): ray queries for everything,
//   the hit point's lights with their shadow rays (ray_query_lights.glsl);
// - REFLECTION_RAYGEN (reflections.rgen, the ray-tracing-pipeline tier): traceRayEXT with four
//   miss shaders and five hit groups (REFLECTION_SBT_*): the reflection ray's closest hit
//   (reflections.rchit, with reflections.rahit for masked and blended surfaces), the decal
//   pass's blending decal shaders, the ray-query lights' light shaders, the shadow pass's
//   any-hit, and last the decal pass's collecting any-hit (with the decals' miss shader). The
//   unbounded lights (the sun) send their shadow rays from here; of the lights found in their
//   TLAS by an any-hit shader, which cannot trace, the LIGHT_SHADOW_SLOTS that contribute most
//   come back for their shadow rays from here, the rest are added unshadowed.
//
// Along the ray, alpha-masked surfaces are alpha-tested (alpha_mask.glsl) and blended ones
// (glass) do not stop it: up to REFLECTION_GLASS panes in front of the hit are shaded and
// blended over it back to front by their opacity, as the transparency passes draw glass on
// screen (back faces only on double-sided materials). A miss sees the clear colour (the sky).
//
// Work is done per cell: a pixel at full resolution, a 2×2 block at half (REFLECT_HALF_RES),
// whose first pixel that reflects traces for the block. With GLASS_LAYER the surfaces are the
// nearest blended ones, found by a camera ray, for the forward transparency pass's glass. Every pixel stores its weight; the cell
// stores the ray's radiance and what it found (reflection_rays: see pack_cell).
#ifndef REFLECTIONS_GLSL
#define REFLECTIONS_GLSL
#extension GL_EXT_control_flow_attributes : require

#ifdef REFLECTION_RAY_QUERY
#define DECALS_AT_HITS   // shading.glsl's traced_decals at the hit points
#endif
// The ray-tracing-pipeline tier's hit groups and miss shaders, in the shader binding table's order.
#define REFLECTION_SBT_SCENE 0
#define REFLECTION_SBT_DECALS 1
#define REFLECTION_SBT_LIGHTS 2
#define REFLECTION_SBT_SHADOWS 3
#define REFLECTION_SBT_DECALS_COLLECT 4   // hit group only (its misses are REFLECTION_SBT_DECALS's)
#include "visbuffer_surface.glsl"
#include "alpha_mask.glsl"
#include "brdf.glsl"
#include "environment.glsl"
#ifdef GBUFFER
#include "deferred_surface.glsl"
#endif

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
    uint decals_tested;   // at the hit point (and the glass panes')
    uint lights_found;
};

// The hit and the glass in front of it, as the traversal leaves them.
struct ReflectionHits {
    bool hit;
    uvec2 ids;            // instance slot, triangle
    vec2 bary;
    float t;
    uint panes;
    float glass_t[REFLECTION_GLASS];
    uvec2 glass_ids[REFLECTION_GLASS];
    vec2 glass_bary[REFLECTION_GLASS];
};

// Whether a candidate hit on a blended instance is a pane the transparency passes draw (its
// front face, or either face when double-sided), for a ray along `dir`.
bool glass_pane_faces(uint instance, uint triangle, GpuMaterial m, vec3 dir) {
    InstanceTriangle t = instance_triangle(instance, triangle);
    return (m.flags & MATERIAL_DOUBLE_SIDED) != 0u || dot(cross(t.p1 - t.p0, t.p2 - t.p0), dir) < 0.0;
}

// A candidate hit on a non-opaque instance (masked or blended): remembers glass in `h` and
// returns false (the ray goes on); true when a masked texel stops the ray.
bool reflection_candidate(inout ReflectionHits h, uint instance, uint triangle, vec2 bary, float t, vec3 dir) {
    GpuInstance inst = scene.instances.instances[instance];
    GpuMaterial m = scene.materials.materials[inst.material];
    if ((m.flags & MATERIAL_BLEND) != 0u) {
        if (h.panes < REFLECTION_GLASS && glass_pane_faces(instance, triangle, m, dir)) {
            h.glass_t[h.panes] = t;
            h.glass_ids[h.panes] = uvec2(instance, triangle);
            h.glass_bary[h.panes] = bary;
            ++h.panes;
        }
        return false;
    }
    return (m.flags & MATERIAL_ALPHA_MASK) == 0u || hit_base_color(inst, m, triangle, bary).a >= m.alpha_cutoff;
}

#ifdef REFLECTION_HIT_SHADERS
// reflections.rchit, .rahit and .rmiss: the payload only.
#else

// The cone's width `t` metres along a reflection ray that left a surface where it was `width0`
// across, spreading by `spread` radians.
float cone_width(float width0, float spread, float t) {
    return width0 + spread * t;
}

#ifdef REFLECTION_RAY_QUERY
#extension GL_EXT_ray_query : require
#include "ray_query_lights.glsl"

ReflectionHits trace_hits(vec3 origin, vec3 dir) {
    ReflectionHits h;
    h.panes = 0u;
    rayQueryEXT q;
    rayQueryInitializeEXT(q, accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsNoneEXT, 0xFF, origin, 0.0, dir,
                          REFLECTION_MAX_DISTANCE);
    // Only masked and blended instances are non-opaque in the scene TLAS, so only they come here.
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) != gl_RayQueryCandidateIntersectionTriangleEXT) continue;
        if (reflection_candidate(h, rayQueryGetIntersectionInstanceCustomIndexEXT(q, false), rayQueryGetIntersectionPrimitiveIndexEXT(q, false),
                                 rayQueryGetIntersectionBarycentricsEXT(q, false), rayQueryGetIntersectionTEXT(q, false), dir)) {
            rayQueryConfirmIntersectionEXT(q);
        }
    }
    h.hit = rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionTriangleEXT;
    if (h.hit) {
        h.ids = uvec2(rayQueryGetIntersectionInstanceCustomIndexEXT(q, true), rayQueryGetIntersectionPrimitiveIndexEXT(q, true));
        h.bary = rayQueryGetIntersectionBarycentricsEXT(q, true);
        h.t = rayQueryGetIntersectionTEXT(q, true);
    }
    return h;
}

// The decals at a hit point, from the same ray queries as on screen.
uint hit_decals(inout SurfaceInputs s) {
    if ((scene.lighting.lighting.reflection_flags & REFLECT_DECALS) == 0u) return 0u;
    return traced_decals(s);
}

// The lights at a hit point, each with its shadow ray.
vec3 hit_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found) {
    return enumerated_lights(brdf, s, v, found);
}
#endif

#ifdef REFLECTION_RAYGEN
#extension GL_EXT_ray_tracing : require
#define LIGHT_RAYGEN
#define SHADOWED_LIGHTS
#define LIGHT_PAYLOAD_LOCATION 2
#define LIGHT_SBT_OFFSET REFLECTION_SBT_LIGHTS
#include "ray_pipeline_lights.glsl"
#define DECAL_BLENDING_RAYGEN   // decal_pass.glsl's collect_decals and blend_decals
#define DECAL_SBT_COLLECT REFLECTION_SBT_DECALS_COLLECT
#define DECAL_SBT_BLEND REFLECTION_SBT_DECALS
#define DECAL_MISS REFLECTION_SBT_DECALS
#define DECAL_COLLECT_LOCATION 4
#define DECAL_BLEND_LOCATION 1
#include "decal_pass.glsl"

layout(location = 0) rayPayloadEXT ReflectionHits reflection_payload;
layout(location = 3) rayPayloadEXT vec4 shadow_payload;

ReflectionHits trace_hits(vec3 origin, vec3 dir) {
    reflection_payload.panes = 0u;
    reflection_payload.hit = false;
    traceRayEXT(accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsNoneEXT, 0xFF, REFLECTION_SBT_SCENE, 0,
                REFLECTION_SBT_SCENE, origin, 0.0, dir, REFLECTION_MAX_DISTANCE, 0);
    return reflection_payload;
}

// Whether the decals at this cell's hit points are likely more than the collecting payload
// keeps: guessed from the count the on-screen decal pass left at the tracing pixel, where it
// ran (decals found by the ray-tracing pass, the cluster list's length by the clustered one).
// A wrong guess costs time, never decals; reflection_cell sets it.
bool decals_dense = false;

// The decals at the hit point, found by zero-length rays in the decal TLAS and blended here
// (decal_pass.glsl's collect_decals and blend_decals, as the on-screen decal pass does).
uint hit_decals(inout SurfaceInputs s) {
    if (scene.decal_count == 0u || !decals_traced() || (scene.lighting.lighting.reflection_flags & REFLECT_DECALS) == 0u) return 0u;
    DecalSurface surface = decal_world_view(s.position, s.dpdx, s.dpdy, s.geometric_normal, s.normal, s.decal_layers);
    DecalBlend b;
    blend_init(b);
    uint tested = 0u;
    // The world's view, then a posed surface's skin view: a loop, so that their traces are one
    // site each (TRACE_DECALS).
    [[dont_unroll]] for (uint view = 0u; view < (s.skinned ? 2u : 1u); ++view) {
        DecalSurface at = view == 0u ? surface : decal_skin_view(surface, s.rest_position, s.rest_normal);
        if (!decals_dense) collect_decals(at);
        tested += blend_decals(b, at, decals_dense);
    }
    blend_resolve(b, s.albedo, s.normal, s.roughness, s.metallic, s.emissive);
    return tested;
}

// Light `light`'s (in slot `slot`) radiance `c` at `p` (facing `facing`), through its shadow ray
// when `shadows`: aimed at a point of the light's shape, as the ray-query lights aim theirs
// (`shadow_sample_at`: a hash of the point, the light and the frame), so that a light with a
// size casts soft shadows in reflections too.
vec3 shadowed_light(GpuLight light, uint slot, vec3 c, vec3 p, vec3 facing, bool shadows) {
    vec3 dir;
    float tmax;
    if (!shadows || all(equal(c, vec3(0.0)))) return c;
    if (!shadow_ray_sampled(light, p, shadow_sample_at(p, slot), dir, tmax)) return vec3(0.0);
    shadow_payload = vec4(1.0, 1.0, 1.0, 0.0);
    traceRayEXT(accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsTerminateOnFirstHitEXT | gl_RayFlagsSkipClosestHitShaderEXT,
                0xFF, REFLECTION_SBT_SHADOWS, 0, REFLECTION_SBT_SHADOWS, shadow_origin(p, facing), 1e-3, dir, tmax, 3);
    return shadow_payload.w != 0.0 ? c * shadow_payload.rgb : vec3(0.0);
}

vec3 hit_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found) {
    GpuLighting l = scene.lighting.lighting;
    found = 0u;
    if (l.light_tlas == 0ul) return vec3(0.0);
    bool shadows = (l.flags & SHADOWS_TRACED) != 0u;
    vec3 facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
    UnboundedLightsRef unbounded = UnboundedLightsRef(l.unbounded_lights);
    uint unbounded_count = unbounded.count;
    light_payload.brdf = brdf;
    light_payload.normal = s.normal;
    light_payload.view = v;
    light_payload.color = vec3(0.0);
    light_payload.found = 0u;
    for (uint i = 0u; i < LIGHT_SHADOW_SLOTS; ++i) {
        light_payload.slots[i] = NO_SHADOWED_LIGHT;
        light_payload.slot_color[i] = vec3(0.0);
    }
    traceRayEXT(accelerationStructureEXT(l.light_tlas), gl_RayFlagsNoOpaqueEXT | gl_RayFlagsSkipClosestHitShaderEXT, 0xFF, REFLECTION_SBT_LIGHTS,
                0, REFLECTION_SBT_LIGHTS, s.position, 0.0, vec3(1.0, 0.0, 0.0), 0.0, 2);
    found = unbounded_count + light_payload.found;
    vec3 color = light_payload.color;   // beyond the strongest few: unshadowed
    // The unbounded lights, then the strongest few the light ray kept, each through its shadow
    // ray: one loop, kept a loop, so that the shadow ray is one traceRayEXT (lavapipe inlines
    // every hit group's any-hit and intersection shaders at each).
    [[dont_unroll]] for (uint k = 0u; k < unbounded_count + LIGHT_SHADOW_SLOTS; ++k) {
        uint slot;
        vec3 c;
        if (k < unbounded_count) {
            slot = unbounded.slots[k];
            c = shade_light(scene.lights.lights[slot], brdf, s.position, s.normal, v);
        } else {
            slot = light_payload.slots[k - unbounded_count];
            if (slot == NO_SHADOWED_LIGHT) continue;
            c = light_payload.slot_color[k - unbounded_count];
        }
        color += shadowed_light(scene.lights.lights[slot], slot, c, s.position, facing, shadows);
    }
    return color;
}
#endif

#if defined(REFLECTION_RAY_QUERY) || defined(REFLECTION_RAYGEN)
// A hit surface's radiance towards `v`: its decals, the ambient term, emission and its lights.
vec3 shade_hit(SurfaceInputs s, vec3 v, inout ReflectionRay r) {
    r.decals_tested += hit_decals(s);
    SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
    vec3 color = s.emissive + ambient_light(brdf, s.normal, v, s.occlusion);
    uint found;
    color += hit_lights(brdf, s, v, found);
    r.lights_found += found;
    return color;
}

// Traces the reflection ray origin + t·dir and shades what it sees.
ReflectionRay trace_reflection(vec3 origin, vec3 dir, float width0, float spread) {
    ReflectionRay r = ReflectionRay(vec3(0.0), REFLECTION_MAX_DISTANCE, false, false, 0u, 0u);
    ReflectionHits h = trace_hits(origin, dir);
    r.hit = h.hit;
    r.distance = h.hit ? h.t : REFLECTION_MAX_DISTANCE;
    r.radiance = h.hit ? vec3(0.0) : sky_along(dir);
    // The opaque hit, then the glass in front of it blended over it back to front as the
    // transparency passes blend it on screen: each pane shaded, over what lies behind by its
    // opacity. One loop, kept a loop, so that shade_hit and the rays it traces are compiled once
    // (lavapipe inlines every hit group at each traceRayEXT and each ray query).
    bool opaque = h.hit;
    [[dont_unroll]] for (uint done = 0u; done <= h.panes; ++done) {
        uint far = REFLECTION_GLASS;
        if (!opaque) {
            for (uint i = 0u; i < h.panes; ++i) {
                if (h.glass_t[i] < r.distance && (far == REFLECTION_GLASS || h.glass_t[i] > h.glass_t[far])) far = i;
            }
            if (far == REFLECTION_GLASS) break;
            r.glass = true;
        }
        uvec2 ids = opaque ? h.ids : h.glass_ids[far];
        float t = opaque ? h.t : h.glass_t[far];
        VisibleSurface v = hit_surface(ids.x, ids.y, opaque ? h.bary : h.glass_bary[far], dir, cone_width(width0, spread, t));
        float opacity = opaque ? 1.0 : clamp(sample_material(v.material, v.uv, v.duvdx, v.duvdy).base.a, 0.0, 1.0);
        r.radiance = mix(r.radiance, shade_hit(surface_inputs(v), -dir, r), opacity);
        if (!opaque) h.glass_t[far] = REFLECTION_MAX_DISTANCE;   // done
        opaque = false;
    }
    return r;
}

#endif

#ifdef REFLECTION_SCREEN_SPACE
#include "depth_pyramid.glsl"
// Screen-space reflections, where there is no ray tracing (or when asked for): a hierarchical
// depth march. The ray, projected to the screen, is followed through the nearest-depth pyramid
// (reflection_hiz.comp): where it passes in front of a pyramid texel it skips the whole texel
// and climbs a level; where it may pass behind, it descends, down to the depth buffer's pixels,
// where a surface no thicker than REFLECTION_THICKNESS it has gone behind is a hit, and the ray
// sees the lit image there (this frame's, before reflections and glass). So only what is on
// screen is reflected, decals included; rays that leave the screen or pass behind everything
// see the clear colour, faded in over the last tenth of the screen's edge.
const float REFLECTION_THICKNESS = 0.25;   // metres, plus 2 % of the distance
const int REFLECTION_MARCH_STEPS = 128;

// Pixel position and reverse-Z depth of clip-space point `h`.
vec3 screen_of(vec4 h) {
    vec2 ndc = h.xy / h.w;
    return vec3((ndc * vec2(0.5, -0.5) + 0.5) * scene.camera.camera.viewport_size, h.z / h.w);
}

// Distance along the view axis of reverse-Z depth `depth` (infinite far plane).
float view_depth(float depth) {
    GpuCamera cam = scene.camera.camera;
    return cam.proj[3][2] / max(depth + cam.proj[2][2], 1e-9);
}

// The nearest depth of the texel of pyramid level `level` (-1: the depth buffer) holding `cell`.
float nearest_depth(int level, ivec2 cell) {
    if (level < 0) return texelFetch(depth_target, cell, 0).r;
    uvec2 viewport = uvec2(scene.camera.camera.viewport_size);
    uvec2 size = hiz_size(viewport, uint(level));
    uvec2 t = min(uvec2(cell), size - 1u);
    return HizRef(scene.lighting.lighting.reflection_hiz).depth[hiz_offset(viewport, uint(level)) + t.y * size.x + t.x];
}

ReflectionRay trace_reflection(vec3 origin, vec3 dir, float width0, float spread) {
    GpuCamera cam = scene.camera.camera;
    ReflectionRay r = ReflectionRay(sky_along(dir), REFLECTION_MAX_DISTANCE, false, false, 0u, 0u);
    // Clip the ray where it would cross the near plane (and at 100 m).
    float near = cam.proj[3][2];
    vec3 forward = -vec3(cam.view[0][2], cam.view[1][2], cam.view[2][2]);
    float towards = dot(dir, forward);
    float origin_depth = dot(origin - cam.position, forward);
    float reach = towards < 0.0 ? min(100.0, (origin_depth - 2.0 * near) / -towards) : 100.0;
    if (reach <= 0.0) return r;
    vec3 a = screen_of(cam.view_proj * vec4(origin, 1.0));
    vec3 b = screen_of(cam.view_proj * vec4(origin + dir * reach, 1.0));
    vec3 d = b - a;   // pixel position and reverse-Z depth are both affine along the projected ray
    float pixels = max(max(abs(d.x), abs(d.y)), 1e-3);
    vec2 size = cam.viewport_size;
    int top = int(findMSB(uint(max(size.x, size.y)))) - 2;
    int level = 0;
    float s = 1.5 / pixels;   // a pixel and a half from the surface
    for (int i = 0; i < REFLECTION_MARCH_STEPS && s <= 1.0; ++i) {
        vec3 p = a + d * s;
        if (any(lessThan(p.xy, vec2(0.0))) || any(greaterThanEqual(p.xy, size)) || p.z <= 0.0) break;
        float cell_size = level < 0 ? 1.0 : float(2 << level);
        vec2 cell = floor(p.xy / cell_size);
        float nearest = nearest_depth(level, ivec2(cell));
        // Where the ray leaves the texel (just past its far edge), and where its depth would
        // reach the texel's nearest surface.
        vec2 bound = (cell + step(vec2(0.0), d.xy)) * cell_size;
        vec2 exits = mix(vec2(2.0), (bound - a.xy) / d.xy, greaterThan(abs(d.xy), vec2(1e-6)));
        float exit = min(exits.x, exits.y) + 0.01 / pixels;
        if (p.z > nearest) {   // in front of everything in the texel (reverse Z)
            float reaches = d.z < 0.0 ? (nearest - a.z) / d.z : 2.0;
            if (level >= 0 && reaches < exit) {
                s = max(s, reaches);
                --level;
            } else {
                s = exit;
                level = min(level + 1, top);
            }
            continue;
        }
        if (level >= 0) {   // behind some surface of the texel: look closer
            --level;
            continue;
        }
        // Behind this pixel's surface: a hit where it is thin enough, else go on behind it.
        if (view_depth(p.z) - view_depth(nearest) < REFLECTION_THICKNESS + 0.02 * view_depth(nearest)) {
            ivec2 px = ivec2(cell);
            vec2 edge = min(vec2(px), size - 1.0 - vec2(px)) / (0.1 * size);
            r.radiance = mix(r.radiance, texelFetch(hdr_target, px, 0).rgb, clamp(min(edge.x, edge.y), 0.0, 1.0));
            r.hit = true;
            r.distance = reach * s;
            return r;
        }
        s = exit;
        level = 0;
    }
    return r;
}
#endif

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
    mat3 frame = tangent_frame(n);
    vec3 h = sample_ggx_vndf(v * frame, roughness * roughness, u);
    vec3 l = reflect(-v, frame * h);
    return dot(l, n) > 1e-3 ? l : reflect(-v, n);   // below the surface: take the mirror direction
}

layout(set = 0, binding = BINDING_REFLECTION, rgba16f) uniform writeonly image2D reflection_out;
layout(set = 0, binding = BINDING_REFLECTION_WEIGHT, rgba16f) uniform writeonly image2D weight_out;
layout(set = 0, binding = BINDING_REFLECTION_RAYS, r32ui) uniform writeonly uimage2D rays_out;

#ifdef GLASS_LAYER
// The nearest blended surface in front of the pixel's opaque one (the forward transparency
// pass's glass), found by a camera ray: false where there is none. Its decals come from the
// decal TLAS like a hit point's.
bool primary_surface(ivec2 px, out SurfaceInputs s) {
    GpuCamera cam = scene.camera.camera;
    vec3 dir = normalize(ray_dir(vec2(px)));
    float depth = texelFetch(depth_target, px, 0).r;
    float opaque = depth > 0.0 ? 0.999 * length(world_from_depth(vec2(px), depth) - cam.position) : REFLECTION_MAX_DISTANCE;
    ReflectionHits h = trace_hits(cam.position, dir);
    if (h.hit) opaque = min(opaque, h.t);
    uint nearest = REFLECTION_GLASS;
    for (uint i = 0u; i < h.panes; ++i) {
        if (h.glass_t[i] < opaque && (nearest == REFLECTION_GLASS || h.glass_t[i] < h.glass_t[nearest])) nearest = i;
    }
    if (nearest == REFLECTION_GLASS) return false;
    float pixel_angle = 2.0 / (cam.proj[1][1] * cam.viewport_size.y);
    s = surface_inputs(hit_surface(h.glass_ids[nearest].x, h.glass_ids[nearest].y, h.glass_bary[nearest], dir, h.glass_t[nearest] * pixel_angle));
    return true;
}

void apply_primary_decals(inout SurfaceInputs s, ivec2 px) {
    hit_decals(s);
}
#else
bool primary_surface(ivec2 px, out SurfaceInputs s) {
#ifdef GBUFFER
    return deferred_surface(px, s);
#else
    return visbuffer_surface(px, s);
#endif
}

void apply_primary_decals(inout SurfaceInputs s, ivec2 px) {
    apply_surface_decals(s, px);
}
#endif

// What a cell's ray found, in one word for the resolve's statistics and upsample: decals tested
// at its hit points (bits 0–11, saturating), lights found (12–23), pixels of the cell that
// reflect (24–26), whether a ray was traced (27), hit (28), crossed glass (29), and which pixel
// of a 2×2 cell traced it (30–31).
uint pack_cell(ReflectionRay r, uint reflecting, bool traced, uint tracer) {
    uint word = min(r.decals_tested, 4095u) | (min(r.lights_found, 4095u) << 12) | (reflecting << 24) | (tracer << 30);
    if (traced) word |= 1u << 27;
    if (traced && r.hit) word |= 1u << 28;
    if (traced && r.glass) word |= 1u << 29;
    return word;
}

// The reflection pass's work for one cell: each pixel rebuilds its surface as its pipeline's
// shading does, applies the frame's decals the same way (they may make it smoother or rougher)
// and stores its reflection's weight; the cell's first pixel smoother than the cut-off traces.
void reflection_cell(ivec2 cell) {
    GpuCamera cam = scene.camera.camera;
    GpuLighting l = scene.lighting.lighting;
    int side = (l.reflection_flags & REFLECT_HALF_RES) != 0u ? 2 : 1;
    ivec2 size = ivec2(cam.viewport_size);
    ReflectionRay r = ReflectionRay(vec3(0.0), 0.0, false, false, 0u, 0u);
    bool traced = false;
    uint reflecting = 0u, tracer = 0u;
    float distance = 0.0;
    vec3 baseline = vec3(0.0);
    for (int i = 0; i < side * side; ++i) {
        ivec2 px = cell * side + ivec2(i % side, i / side);
        if (any(greaterThanEqual(px, size))) continue;
        SurfaceInputs s;
        if (!primary_surface(px, s)) {
            imageStore(weight_out, px, vec4(0.0, 0.0, 0.0, -1.0));
            continue;
        }
        apply_primary_decals(s, px);
        vec3 v = normalize(cam.position - s.position);
        vec3 facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
        vec3 n = dot(s.normal, v) > 1e-3 ? s.normal : facing;
        float fade = clamp((l.reflection_cutoff - s.roughness) / (0.25 * l.reflection_cutoff), 0.0, 1.0);
        if (fade <= 0.0) {
            imageStore(weight_out, px, vec4(0.0, 0.0, 0.0, -1.0));
            continue;
        }
        SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
        vec3 weight = ambient_specular_weight(brdf, n, v, s.occlusion) * fade;
#ifdef GBUFFER
        // Glass in the G-buffer (interlaced rows, depth peeling's layer) is composed over what is
        // behind it by its opacity α; its reflection is not transmitted light and must stay
        // whole, so it is added as R / α.
        weight /= max(texelFetch(gbuffer_material, px, 0).b, 0.05);
#endif
        imageStore(weight_out, px, vec4(weight, s.roughness));
        ++reflecting;
        if (traced) continue;
        // The pixel's cone: its width where it meets the surface, spreading by a pixel's angle,
        // and by the lobe's width on glossy surfaces.
        traced = true;
        tracer = uint(i);
        float pixel_angle = 2.0 / (cam.proj[1][1] * cam.viewport_size.y);
        distance = length(cam.position - s.position);
        float spread = pixel_angle + (s.roughness < REFLECTION_MIRROR ? 0.0 : 0.5 * s.roughness * s.roughness);
        vec3 dir = reflection_direction(n, v, s.roughness, pixel_noise(uvec2(px)));
#if defined(REFLECTION_RAYGEN) && defined(DECAL_BUFFER)
        decals_dense = imageLoad(decal_tested, px).r > DECAL_COLLECT_MAX;
#endif
#ifdef REFLECTION_SCREEN_SPACE
        vec3 origin = shadow_origin(s.position, facing); // marched on screen: no mesh to stray from
#else
        vec3 origin = raster_origin(s.position, facing);
#endif
        r = trace_reflection(origin, dir, distance * pixel_angle, spread);
        // Shading lit the surface with the environment's prefiltered radiance (or the ambient
        // colour) in the mirror direction; the ray stores what it brings beyond that.
        baseline = ambient_specular(reflect(-v, n), s.roughness);
    }
    vec3 radiance = r.radiance - baseline;
    if (scene.debug_view == DEBUG_REFLECTIONS) radiance = r.hit ? heatmap(r.distance / 16.0) : vec3(1.0);
    imageStore(reflection_out, cell, traced ? vec4(radiance, distance) : vec4(0.0));
    imageStore(rays_out, cell, uvec4(pack_cell(r, reflecting, traced, tracer)));
}

#endif
#endif
