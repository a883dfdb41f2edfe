// Shading shared by every pipeline: given a surface's attributes (from the forward pass's
// varyings, the G-buffer, or the visibility buffer's reconstruction), apply decals, answer the
// debug views, and light it. Decals come from in-shader ray queries (RAY_QUERY_DECALS variants)
// or from the decal buffer a decal pass wrote (DECAL_BUFFER variants), or, in the forward
// pipelines when FrameSettings::decals_in_forward_shading asks, from the lists of clustered
// decals walked right here (CLUSTERED_DECALS variants: the surface's own position,
// normal-mapped normal and derivatives, no decal pass and no ids prepass), when the frame has
// any.
// Lights come from the pixel's list (its tile's after light culling, or every light; see
// light_tiles.glsl), each weighted by the shadow pass's bit when shadows were traced (the
// visibility term V of seed 001 eq. 4.4), or, where the pixel sampled them, unshadowed and
// scaled by the sampled share that got through (direct_sampling.glsl). With ray-query lights (ENUMERATED_LIGHTS: the
// including shader defines `enumerated_lights`, ray_query_lights.glsl or
// ray_pipeline_lights.glsl) the lights come from a zero-length ray instead of a list.
#ifndef SHADING_GLSL
#define SHADING_GLSL
#extension GL_EXT_control_flow_attributes : require

#ifdef CLUSTERED_DECALS
#define DECAL_BLEND_ONE_CHANNEL   // blend.glsl: a quarter of the blend state (see below)
#endif

#include "scene.glsl"
#include "lighting.glsl"
#include "decals.glsl"
#include "heatmap.glsl"
#include "light_tiles.glsl"
#include "environment.glsl"
#include "storable.glsl"
#include "direct_sampling.glsl"

layout(set = 0, binding = BINDING_SHADOW_DEBUG, rgba16f) uniform readonly image2D shadow_debug_in;
layout(set = 0, binding = BINDING_OCCLUSION, r32f) uniform readonly image2D occlusion_in;
layout(set = 0, binding = BINDING_SHADOW_RATIO, rgba16f) uniform readonly image2D shadow_ratio_in;

// The ambient occlusion at pixel `px` (occlusion.glsl; 1 where its passes did not run). Blended
// surfaces are not in the depth it was made from: they are not occluded.
float ambient_occlusion(ivec2 px) {
#ifdef TRANSPARENT
    return 1.0;
#else
    return (scene.lighting.lighting.flags & AMBIENT_OCCLUSION) != 0u ? imageLoad(occlusion_in, px).r : 1.0;
#endif
}
#ifdef DECAL_BUFFER
#include "decal_buffer.glsl"
#endif
#ifdef CLUSTERED_DECALS
#include "clusters.glsl"
#endif

struct SurfaceInputs {
    vec3 position;
    vec3 dpdx;              // world-position derivatives (for decal mip selection)
    vec3 dpdy;
    vec3 geometric_normal;  // for the decal angle fade
    vec3 normal;            // shading normal (normal-mapped)
    vec3 albedo;
    float roughness;
    float metallic;
    float occlusion;
    vec3 emissive;
    uint decal_layers;
    bool skinned;           // a posed mesh: decals on its skin are looked up at its rest pose
    vec3 rest_position;
    vec3 rest_normal;
};

#ifdef ENUMERATED_LIGHTS
// The radiance of every light reaching the surface, and how many were found.
vec3 enumerated_lights(SurfaceBrdf brdf, SurfaceInputs s, vec3 v, out uint found);
#endif

#if defined(RAY_QUERY_DECALS) || defined(DECALS_AT_HITS)
// Applies the decals at surface `s` that zero-length ray queries in the decal TLAS find (seed
// 000 §4.2.2), those of the world and, on a skin, those at its rest pose; returns the decals
// tested. The primary surface's ray-query decals and the reflection rays' hit points share it.
uint traced_decals(inout SurfaceInputs s) {
    if (scene.decal_count == 0u || !decals_traced()) return 0u;
    DecalSurface surface = decal_world_view(s.position, s.dpdx, s.dpdy, s.geometric_normal, s.normal, s.decal_layers);
    DecalBlend blend;
    blend_init(blend);
    uint tested = 0u;
    // The world's view, then a posed surface's skin view: a loop, so that the query is one
    // site (gather_decals).
    [[dont_unroll]] for (uint view = 0u; view < (s.skinned ? 2u : 1u); ++view) {
        tested += gather_decals(blend, view == 0u ? surface : decal_skin_view(surface, s.rest_position, s.rest_normal));
    }
    blend_resolve(blend, s.albedo, s.normal, s.roughness, s.metallic, s.emissive);
    return tested;
}
#endif

// Applies the frame's decals to surface `s` at pixel `px` the way this variant finds them
// (none, ray queries, the decal buffer or the cluster lists); returns the decals tested.
uint apply_surface_decals(inout SurfaceInputs s, ivec2 px) {
    uint decals_tested = 0u;
#ifdef RAY_QUERY_DECALS
    decals_tested = traced_decals(s);
#endif
#ifdef CLUSTERED_DECALS
    if (scene.decal_count > 0u) {
        // The blend state only where some decal lands, and one channel's at a time: in a
        // fragment shader that also loops over lights, 100 decals made the lent H100's forward
        // pass 71 % slower with four channels' state everywhere, 57 % with it only where a decal
        // lands, 38 % with one channel's (docs/BENCHMARKS.md, "Decals in PEERS.md's scene").
        DecalSurface surface = decal_world_view(s.position, s.dpdx, s.dpdy, s.geometric_normal, s.normal, s.decal_layers);
        uvec2 list = cluster_list(uvec2(px), s.position);
        decals_tested = list.y > list.x ? list.y - list.x : 0u;
        uint channels = landing_channels(list, surface);
        DecalSurface skin = surface;
        if (s.skinned) {   // the same list at the rest pose (decals on a skin are binned by its posed bounds)
            skin = decal_skin_view(surface, s.rest_position, s.rest_normal);
            channels |= landing_channels(list, skin);
            decals_tested *= 2u;
        }
        if (channels != 0u) {
            DecalComposite composite = blend_identity();
            for (uint c = 0u; c < DECAL_CHANNELS; ++c) {
                if ((channels & (1u << c)) == 0u) continue;
                DecalBlend blend;
                blend_init(blend);
                apply_cluster_channel(blend, list, surface, c);
                if (s.skinned) apply_cluster_channel(blend, list, skin, c);
                blend_collapse_onto(composite, blend);
            }
            blend_apply(composite, s.albedo, s.normal, s.roughness, s.metallic, s.emissive);
        }
    }
#endif
#ifdef DECAL_BUFFER
    if (scene.decal_count > 0u) decals_tested = decal_buffer_apply(px, s.albedo, s.normal, s.roughness, s.metallic, s.emissive);
#endif
    return decals_tested;
}

#ifdef TILE_SHARED_LIGHTS
// Staged lights (the compute shading passes, in frames whose lists are unshadowed). A
// workgroup of 64 threads (8×8) lies inside one light tile (8, 16 or 32 pixels), so its pixels
// share one list. Where that list is unshadowed (sampled shadows, or none), the workgroup reads
// it 64 entries at a time: each thread fetches one listed light's record, keeps it if the light's
// range reaches the box around the workgroup's surface points, and the kept records go to shared
// memory in list order; every thread then loops over them. Without staging, each thread reads a
// slot and then the record it names, one light after the other: those loads were half the
// loop's time in the many-lights scene (docs/experiments/lights-shading-loop.md). A light out of
// range contributes 0 and the order is kept, so the image is the same. Shadowed lists are walked
// a thread at a time as without staging (a light whose bit is off is then never read).
// Every thread of a staging workgroup calls shade_surface_in_group (those with no surface with
// `shades` false: they help stage and shade nothing), so that the barriers are reached by all;
// a workgroup with no surface stages nothing.
//
// Whether this pipeline stages (a specialization constant: only in frames where pixels sample
// their shadows or none are made, and the scene has more than a chunk of lights, for its registers
// slow the lists walked a thread at a time; render::gpu::pipeline::Specialization).
layout(constant_id = SPEC_STAGED_LIGHTS) const bool STAGED_LIGHTS = false;
const uint LIGHT_STAGE = STAGED_LIGHTS_CHUNK;
const uint STAGE_WORDS = LIGHT_STAGE / 32u;
// Pipelines that do not stage take (almost) no shared memory: with the 4 KB of the staged
// records, the H200's compiler gave the unstaged loop 96 registers instead of 64, and it ran 18 %
// slower.
const uint STAGE_SLOTS = STAGED_LIGHTS ? LIGHT_STAGE : 1u;
shared GpuLight staged_lights[STAGE_SLOTS];
shared uint staged_entries[STAGE_SLOTS];
shared uint staged_kept[STAGED_LIGHTS ? 2u * STAGE_WORDS : 1u];   // by chunk parity: the next chunk's are cleared early
shared uint group_box[STAGED_LIGHTS ? 6u : 1u];   // the low corner's ordered bits, then the high's
shared bool staged_areas;

// A float's bits, ordered as unsigned integers are (for shared atomic min and max).
uint ordered_bits(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float from_ordered_bits(uint u) {
    return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7FFFFFFFu : ~u);
}

// The box around the surface points of the workgroup's threads that shade (false: none does).
bool group_bounds(vec3 p, bool shades, out vec3 lo, out vec3 hi) {
    if (gl_LocalInvocationIndex < 3u) {
        group_box[gl_LocalInvocationIndex] = 0xFFFFFFFFu;
        group_box[3u + gl_LocalInvocationIndex] = 0u;
    }
    barrier();
    if (shades) {
        for (uint i = 0u; i < 3u; ++i) {
            atomicMin(group_box[i], ordered_bits(p[i]));
            atomicMax(group_box[3u + i], ordered_bits(p[i]));
        }
    }
    barrier();
    lo = vec3(from_ordered_bits(group_box[0]), from_ordered_bits(group_box[1]), from_ordered_bits(group_box[2]));
    hi = vec3(from_ordered_bits(group_box[3]), from_ordered_bits(group_box[4]), from_ordered_bits(group_box[5]));
    return group_box[3] != 0u;
}

// Whether `light` can light some point of the box [lo, hi] (its distance window is 0 at and
// beyond its range).
bool reaches_box(GpuLight light, vec3 lo, vec3 hi) {
    if (light.kind == LIGHT_NONE) return false;
    if (light.kind == LIGHT_DIRECTIONAL) return true;
    vec3 d = max(max(lo - light.position, light.position - hi), vec3(0.0));
    return dot(d, d) < light.range * light.range;
}
#endif

// One listed light's share of a pixel's light (the body of shade_surface_in_group's loops):
// added to `direct`, the sum the sampled shadows' ratio scales, or, for a sun a sampling pixel
// traced (`sun_bits` its rays' answers), to `color` where its ray got through. `entry` is the
// light's place in `list`; where `tinted`, the glass it crossed tints it (read from the tint
// words at `tint_at` only for a light that is shaded). The pass over `areas` (the area lights,
// or the others) skips the other kind and notes in `areas_listed` that it met one.
void add_listed_light(GpuLight light, bool areas, bool tinted, uint tint_at, SurfaceBrdf brdf, SurfaceInputs s, vec3 v,
                      bool suns_traced, uint sun_bits, LightList list, uint entry, inout vec3 direct, inout vec3 color,
                      inout bool areas_listed) {
    if (light.kind == LIGHT_NONE) return;
    if (is_area_light(light) != areas) {
        areas_listed = true;
        return;
    }
    vec3 lit = shade_light_of(light, brdf, s.position, s.normal, v, areas);
    if (tinted) lit *= shadow_tint_of(tint_at, entry);
    int sun = -1;
    if (suns_traced && light.kind == LIGHT_DIRECTIONAL) sun = sun_index(sampling_suns(), light_slot(list, entry));
    if (sun < 0) {
        direct += lit;
    } else if ((sun_bits & (1u << uint(sun))) != 0u) {
        color += lit;
    }
}

#ifdef TILE_SHARED_LIGHTS
// Pass `pass` (over `areas`) of a staging workgroup: the tile's `staged_count` listed lights, a
// chunk at a time, kept where they reach the box [group_lo, group_hi] of the workgroup's surface
// points, and shaded from shared memory by the threads that `shades`. Every thread of the
// workgroup calls it alike (its barriers); after pass 0 `areas_listed` says for all of them
// whether the list holds an area light.
void shade_staged_lights(int pass, bool areas, uint staged_count, vec3 group_lo, vec3 group_hi, LightList list, bool shades,
                         SurfaceBrdf brdf, SurfaceInputs s, vec3 v, bool suns_traced, uint sun_bits, inout vec3 direct,
                         inout vec3 color, inout bool areas_listed) {
    uint lid = gl_LocalInvocationIndex;
    if (pass == 0 && lid == 0u) staged_areas = false;
    if (lid < STAGE_WORDS) staged_kept[lid] = 0u;
    for (uint base = 0u; base < staged_count; base += LIGHT_STAGE) {
        uint parity = (base / LIGHT_STAGE) & 1u;
        barrier();   // every thread is done with the last chunk
        if (lid < STAGE_WORDS) staged_kept[(parity ^ 1u) * STAGE_WORDS + lid] = 0u;
        uint at = base + lid;
        GpuLight staged;
        bool kept = false;
        if (at < staged_count) {
            staged = scene.lights.lights[light_slot(list, at)];
            if (pass == 0 && is_area_light(staged)) staged_areas = true;
            kept = reaches_box(staged, group_lo, group_hi);
            if (kept) atomicOr(staged_kept[parity * STAGE_WORDS + lid / 32u], 1u << (lid % 32u));
        }
        barrier();
        // Compacted in list order: a kept light's place is the number kept before it.
        uint below = 0u, kept_count = 0u;
        for (uint w = 0u; w < STAGE_WORDS; ++w) {
            uint bits = staged_kept[parity * STAGE_WORDS + w];
            if (w < lid / 32u) below += bitCount(bits);
            if (w == lid / 32u) below += bitCount(bits & ((1u << (lid % 32u)) - 1u));
            kept_count += bitCount(bits);
        }
        if (kept) {
            staged_lights[below] = staged;
            staged_entries[below] = at;
        }
        barrier();
        for (uint k = 0u; k < (shades ? kept_count : 0u); ++k) {
            add_listed_light(staged_lights[k], areas, false, 0u, brdf, s, v, suns_traced, sun_bits, list, staged_entries[k], direct, color, areas_listed);
        }
    }
    // The same answer for every thread: the second pass's barriers are reached by all.
    if (pass == 0) areas_listed = staged_count > 0u && staged_areas;
}
#endif

// `px` is the pixel being shaded (its tile's lights, its shadow bits, its decal buffer texel);
// `shades` is false for a thread of a TILE_SHARED_LIGHTS workgroup that has no surface to shade.
vec4 shade_surface_in_group(SurfaceInputs s, ivec2 px, bool shades) {
    if (scene.debug_view == DEBUG_LOD) return vec4(s.albedo, 1.0); // the level's colour, set where the surface was built
    uint decals_tested = shades ? apply_surface_decals(s, px) : 0u;
    if (scene.debug_view == DEBUG_ALBEDO) return vec4(s.albedo, 1.0);
    if (scene.debug_view == DEBUG_NORMAL) return vec4(s.normal * 0.5 + 0.5, 1.0);
    if (scene.debug_view == DEBUG_ROUGHNESS_METALLIC) return vec4(s.roughness, s.metallic, 0.0, 1.0);
    if (scene.debug_view == DEBUG_DECAL_COUNT || scene.debug_view == DEBUG_DECAL_FLOOR) return vec4(float(decals_tested), 0.0, 0.0, 1.0);
    if (scene.debug_view == DEBUG_DECAL_HEATMAP) return vec4(heatmap(float(decals_tested) / 16.0), 1.0);
    // A thread that does not shade may lie outside the viewport: it reads no image at `px`.
    float occlusion = s.occlusion * (shades ? ambient_occlusion(px) : 1.0);
    if (scene.debug_view == DEBUG_AMBIENT_OCCLUSION) return vec4(vec3(occlusion), 1.0);

    GpuCamera cam = scene.camera.camera;
    vec3 v = normalize(cam.position - s.position);
    SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
    vec3 color = s.emissive + ambient_light(brdf, s.normal, v, occlusion);
#ifdef ENUMERATED_LIGHTS
    uint found;
    color += enumerated_lights(brdf, s, v, found);
    if (scene.debug_view == DEBUG_LIGHT_COUNT) return vec4(float(found), 0.0, 0.0, 1.0);
    if (scene.debug_view == DEBUG_LIGHT_HEATMAP) return vec4(heatmap(float(found) / 32.0), 1.0);
    // No shadow pass ran: its views show black.
    if (scene.debug_view == DEBUG_SHADOW_FIRST || scene.debug_view == DEBUG_SHADOW_RAYS) return vec4(0.0, 0.0, 0.0, 1.0);
    if (scene.debug_view == DEBUG_DEPTH_NORMALS) {
        bool reconstructed = float(px.x) < scene.camera.camera.viewport_size.x * 0.5;
        return vec4(reconstructed ? vec3(0.0) : s.normal * 0.5 + 0.5, 1.0);
    }
#else
    LightList list = light_list(px);
#if defined(TRANSPARENT) && !defined(SHADOWED_GLASS)
    bool shadowed = false;   // no glass layer this frame: the shadow bits are the opaque surface's
    uint layer_words = 0u, layer_tints = 0u;
#elif defined(TRANSPARENT)
    // A blended surface has shadows when it is the nearest one at its pixel: the shadow pass's
    // glass layer ran over the transparent depth (GLASS_SHADOWS). Glass behind glass is lit
    // unshadowed. (Same geometry, same vertex shader: the depths agree to rounding.) A variant
    // of its own: the dynamic shadow code cost the unshadowed pass 22 % on the lent H100.
    bool glass_layer = list.rows != NO_SHADOW_ROWS && (scene.lighting.lighting.flags & GLASS_SHADOWS) != 0u;
    float nearest_glass = glass_layer ? texelFetch(transparent_depth, px, 0).r : 0.0;
    bool shadowed = glass_layer && abs(gl_FragCoord.z - nearest_glass) <= 1e-5 * nearest_glass;
    uint layer_words = glass_layer_words(), layer_tints = glass_layer_tints();
#else
    bool shadowed = list.rows != NO_SHADOW_ROWS;
    uint layer_words = 0u, layer_tints = 0u;
#endif
    ShadowWordsRef shadow_words = ShadowWordsRef(scene.lighting.lighting.shadow_bits);
    if (scene.debug_view == DEBUG_LIGHT_COUNT) return vec4(float(list.count), 0.0, 0.0, 1.0);
    if (scene.debug_view == DEBUG_LIGHT_HEATMAP) return vec4(heatmap(float(list.count) / 32.0), 1.0);
    if (scene.debug_view == DEBUG_SHADOW_FIRST) {
        float visible = shadowed && list.count > 0u ? float(shadow_words.words[layer_words + shadow_word_at(list, 0u, px)] & 1u) : 1.0;
        return vec4(visible, float(list.count), float(shadowed), 1.0);
    }
    // The shadow pass's debug image exists only when it ran with its debug output; without it
    // these views show black (no rays, no normals).
#ifdef TRANSPARENT
    // The shadow pass's debug image belongs to the opaque surface behind, and holds nothing
    // where that is the sky.
    bool shadow_debug = false;
#else
    bool shadow_debug = (scene.lighting.lighting.flags & SHADOW_DEBUG) != 0u;
#endif
    if (scene.debug_view == DEBUG_SHADOW_RAYS) return vec4(shadow_debug && shades ? heatmap(imageLoad(shadow_debug_in, px).a / 16.0) : vec3(0.0), 1.0);
    if (scene.debug_view == DEBUG_DEPTH_NORMALS) {
        bool reconstructed = float(px.x) < scene.camera.camera.viewport_size.x * 0.5;
        vec3 rebuilt = shadow_debug && shades ? imageLoad(shadow_debug_in, px).rgb : vec3(0.0);
        return vec4(reconstructed ? rebuilt : s.normal * 0.5 + 0.5, 1.0);
    }

    // A pixel that sampled its lights' shadows (direct_sampling.glsl) sums them unshadowed and
    // takes the denoised share that got through; blended surfaces never sample (their glass
    // layer is exhaustive).
#ifdef TRANSPARENT
    bool sampled = false;
#else
    bool sampled = shadowed && samples_lights(list);
#endif
    // The suns' bits, which a sampling pixel keeps in its first shadow word.
    uint sun_bits = sampled ? shadow_words.words[layer_words + shadow_word_at(list, 0u, px)] : 0u;
    bool suns_traced = sampled && scene.lighting.lighting.sun_count > 0u;
    if (sampled) shadowed = false;
    // The suns and the tint words are read where a light needs them, not held across the loop
    // (docs/experiments/lights-shading-loop.md): the loop is what the pass spends its time in.
    // Held as an array indexed by the light, the tints went to local memory (16 bytes a thread,
    // 56 registers) on the H200 once the suns left the loop, and the many-lights scene's shading
    // took 3.69 ms; read from the tint buffer, 3.56 ms (64 registers, no local memory).
    bool tinted = shadowed && scene.lighting.lighting.shadow_tints != 0ul;
    uint tint_at = layer_tints + shadow_tint_at(px);
    vec3 direct = vec3(0.0);
    // Two passes over the list, each compiled with one kind's code (shade_light_of): the
    // punctual lights, then the area lights where the list holds any (the second pass only in
    // pipelines made with AREA_LIGHTS).
    bool areas_listed = false;
#ifdef TILE_SHARED_LIGHTS
    // Long unshadowed lists (sampled shadows, or none) are staged and culled to the workgroup's
    // box; the rest are walked a thread at a time (a light whose shadow bit is off is then never
    // read, and a list of one chunk or less gains nothing from staging: the peer scene's 28
    // lights shaded about 30 % slower so). Uniform in the workgroup: the list is its tile's, and so is
    // whether it is shadowed.
    bool staging = STAGED_LIGHTS && !shadowed && list.count > LIGHT_STAGE;
    vec3 group_lo = vec3(0.0), group_hi = vec3(0.0);
    uint staged_count = staging && group_bounds(s.position, shades, group_lo, group_hi) ? list.count : 0u;
#else
    const bool staging = false;
    uint staged_count = 0u;
#endif
    [[unroll]] for (int pass = 0; pass < (AREA_LIGHTS ? 2 : 1); ++pass) {
        if (pass == 1 && !areas_listed) break;
        bool areas = pass == 1;
#ifdef TILE_SHARED_LIGHTS
        if (staging) {
            shade_staged_lights(pass, areas, staged_count, group_lo, group_hi, list, shades, brdf, s, v, suns_traced, sun_bits,
                                direct, color, areas_listed);
        }
#endif
        if (!staging) {
            uint word = 0xFFFFFFFFu;
            for (uint j = 0u; j < (shades ? list.count : 0u); ++j) {
                if (shadowed && j % 32u == 0u) word = shadow_words.words[layer_words + shadow_word_at(list, j, px)];
                if ((word & (1u << (j % 32u))) == 0u) continue;
                GpuLight light = scene.lights.lights[light_slot(list, j)];
                add_listed_light(light, areas, tinted, tint_at, brdf, s, v, suns_traced, sun_bits, list, j, direct, color, areas_listed);
            }
        }
    }
    color += sampled && shades ? direct * imageLoad(shadow_ratio_in, px).rgb : direct;
#endif
    return vec4(storable_radiance(color), 1.0);
}

#ifndef TILE_SHARED_LIGHTS
// `px` is the pixel being shaded (its tile's lights, its shadow bits, its decal buffer texel).
vec4 shade_surface(SurfaceInputs s, ivec2 px) {
    return shade_surface_in_group(s, px, true);
}
#endif

#endif
