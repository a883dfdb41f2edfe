// Ray-traced shadows (seed 001 §4.3; soft where a light has a size), per pixel and from depth alone, so one pass serves
// every pipeline: the world position from depth (seed alg. 4.1, `world_from_depth`), the normal
// from depth (depth_normals.glsl, naive or improved), then for each light of the pixel's list
// one shadow ray towards it, unless no light reaches the point (out of range, outside a spot's
// cone) or, with shadow-ray culling, the normal faces away from it. Bit k of a row's word is
// set when entry 32·row + k reaches the pixel unblocked (light_tiles.glsl).
//
// With SHADOW_MAPS defined the light's shadow map answers instead (shadow_maps.glsl): a lookup
// at the point, or, for a light with a size, a march of the same sampled ray through the maps.
// GLASS_LAYER: the same over the transparent depth (the nearest blended surface drawn by the
// forward transparency pass), into the glass layer's words and tints (light_tiles.glsl); it
// writes no debug image.
// Otherwise the including shader defines how a ray is traced (ray query or traceRayEXT), returning the
// light that gets through (0: blocked; below 1 where it crossed glass):
//   vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax);
// A ray that crossed glass keeps its colour in one of the pixel's tint slots (light_tiles.glsl)
// when there is one free; otherwise its bit says whether more than half the light got through.
// Pixels whose list holds more lights than GpuLighting::sampled_lights_above trace one ray
// instead, to a light drawn from the list (direct_sampling.glsl), into the sampled shadows'
// image; the rest write a mark there that they sampled nothing. Not over the glass layer, nor
// with shadow maps: those are exhaustive. SHADOW_MATERIAL (the deferred pipeline, whose
// G-buffer is written before its shadows) weighs the draw through the surface's whole BRDF.
// Rays follow the seed: tmin 0.001, tmax the distance to the light (1000 for directional
// lights), first hit ends the ray; a light with a size (a sphere's radius, a sun's disc) is aimed
// at a point of its disc that changes per pixel and per frame (shadow_ray_sampled, lighting.glsl),
// so that temporal anti-aliasing resolves the penumbra (beyond the seed, whose shadows are hard). The origin is lifted off the surface along the
// reconstructed normal by 0.1 % of its distance to the camera, so that depth quantisation
// cannot put it under its own surface, and by the level-of-detail limit there
// (`raster_origin`, lighting.glsl).
#ifndef SHADOW_PASS_GLSL
#define SHADOW_PASS_GLSL

#include "color.glsl"
#include "scene.glsl"
#include "lighting.glsl"
#include "depth_normals.glsl"
#include "light_tiles.glsl"

layout(set = 0, binding = BINDING_SHADOW_DEBUG, rgba16f) uniform writeonly image2D shadow_debug_out;

#ifdef SHADOW_MAPS
#include "shadow_maps.glsl"
#else
vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax);
#endif

#if !defined(SHADOW_MAPS) && !defined(GLASS_LAYER)
#define SAMPLES_LIGHTS
#include "direct_sampling.glsl"
layout(set = 0, binding = BINDING_SHADOW_SAMPLES, rgba16f) uniform writeonly image2D shadow_samples_out;

// One shadow ray towards a light drawn from `list` (direct_sampling.glsl); writes what got
// through and log2 of the unshadowed estimate it was drawn from; and one ray to each of the
// suns, whose bits (bit k: sun k reaches the pixel) go to the pixel's first shadow word. Returns
// the rays traced.
uint sample_shadow(ivec2 px, LightList list, vec3 p, vec3 n, vec3 origin, bool cull) {
    GpuLighting l = scene.lighting.lighting;
    uint sun_bits = 0u, rays = 0u;
    for (uint k = 0u; k < l.sun_count; ++k) {
        if (l.suns[k] >= l.light_count) continue;
        GpuLight sun = scene.lights.lights[l.suns[k]];
        if (sun.kind != LIGHT_DIRECTIONAL) continue;
        vec3 dir;
        float tmax;
        if (!shadow_ray_sampled(sun, p, shadow_sample(px, l.suns[k]), dir, tmax) || (cull && dot(n, dir) <= 0.0)) continue;
        ++rays;
        if (luminance(shadow_ray_transmittance(origin, dir, 1e-3, tmax)) > 0.5) sun_bits |= 1u << k;
    }
    ShadowWordsRef(l.shadow_bits).words[shadow_word_at(list, 0u, px)] = sun_bits;
    uint seed = light_draw_seed(px);
#ifdef SHADOW_MATERIAL
    // The G-buffer's surface, as the deferred lighting pass will shade it (before the deferred
    // decals change its material).
    vec3 shading_normal = safe_normalize(texelFetch(gbuffer_normal, px, 0).xyz * 2.0 - 1.0, n);
    vec2 rm = texelFetch(gbuffer_material, px, 0).rg;
    SurfaceBrdf brdf = surface_brdf(texelFetch(gbuffer_albedo, px, 0).rgb, rm.g, rm.r);
    DrawPoint at = DrawPoint(p, shading_normal, normalize(scene.camera.camera.position - p), brdf);
#else
    DrawPoint at = DrawPoint(p, n);
#endif
    LightSample chosen = draw_light(list, at, seed);
    vec3 through = vec3(0.0);
    if (chosen.slot != NO_SLOT) {
        GpuLight light = scene.lights.lights[chosen.slot];
        vec3 dir;
        float tmax;
        if (shadow_ray_sampled(light, p, shadow_sample(px, chosen.slot), dir, tmax) && !(cull && dot(n, dir) <= 0.0)) {
            through = shadow_ray_transmittance(origin, dir, 1e-3, tmax);
            ++rays;
        }
    }
    imageStore(shadow_samples_out, px, vec4(through, chosen.estimate > 0.0 ? max(log2(chosen.estimate), SAMPLED_NONE + 1.0) : SAMPLED_NONE));
    return rays;
}
#endif

void shadow_pixel(ivec2 px) {
    GpuLighting l = scene.lighting.lighting;
    if (!pixel_inside(px)) return;
    float depth = texelFetch(NORMALS_DEPTH, px, 0).r;
    if (depth <= 0.0) return;
#ifdef GLASS_LAYER
    uint layer_words = glass_layer_words(), layer_tints = glass_layer_tints();
#else
    uint layer_words = 0u, layer_tints = 0u;
#endif
    vec3 p = world_from_depth(vec2(px), depth);
    vec3 n = (l.flags & SHADOW_NORMALS_IMPROVED) != 0u ? normal_from_depth_improved(px, depth, p)
                                                        : normal_from_depth_naive(px, depth, p);
    LightList list = light_list(px);
    uint rays = 0u;
#ifdef SAMPLES_LIGHTS
    bool sampled = samples_lights(list);
    if (!sampled && l.sampled_lights_above != 0xFFFFFFFFu) imageStore(shadow_samples_out, px, vec4(1.0, 1.0, 1.0, SAMPLED_NONE));
    if (sampled) {
        rays = sample_shadow(px, list, p, n, raster_origin(p, n), (l.flags & SHADOW_RAY_CULLING) != 0u);
    } else
#endif
    if (list.rows != NO_SHADOW_ROWS) {
        bool cull = (l.flags & SHADOW_RAY_CULLING) != 0u;
        vec3 origin = raster_origin(p, n);
        ShadowWordsRef words = ShadowWordsRef(l.shadow_bits);
        uint tints[SHADOW_TINT_SLOTS];
        for (uint s = 0u; s < SHADOW_TINT_SLOTS; ++s) tints[s] = 0u;
        uint tinted = 0u;
        for (uint base = 0u; base < list.count; base += 32u) {
            uint word = 0u;
            uint here = min(32u, list.count - base);
            for (uint k = 0u; k < here; ++k) {
                uint slot = light_slot(list, base + k);
                GpuLight light = scene.lights.lights[slot];
                vec3 dir;
                float tmax;
                // Towards a point of the light's shape (the light's size: soft shadows).
                vec2 u = shadow_sample(px, slot);
                if (!shadow_ray_sampled(light, p, u, dir, tmax)) continue;
                if (cull && dot(n, dir) <= 0.0) continue;
                ++rays;
#ifdef SHADOW_MAPS
                vec3 centre;
                float centre_tmax;
                shadow_ray_towards(light, p, centre, centre_tmax);
                // Inside a light with a size nothing is between (as for the rays); a light without
                // one (or without temporal anti-aliasing) takes the hard lookup.
                vec3 t = tmax <= 1e-3 ? vec3(1.0)
                       : centre == dir ? shadow_map_transmittance(slot, light, p, n, dir)
                                       : shadow_map_transmittance_sampled(slot, light, p, n, centre, dir, tmax, fract(u.x * 61.0 + u.y));
#else
                vec3 t = shadow_ray_transmittance(origin, dir, 1e-3, tmax);
#endif
                if (all(greaterThanEqual(t, vec3(1.0)))) {
                    word |= 1u << k;
                } else if (l.shadow_tints != 0ul && tinted < SHADOW_TINT_SLOTS && base + k < 255u) {
                    word |= 1u << k;
                    tints[tinted++] = (packUnorm4x8(vec4(t, 0.0)) & 0xFFFFFFu) | ((base + k + 1u) << 24);
                } else if (luminance(t) > 0.5) {
                    word |= 1u << k;
                }
            }
            words.words[layer_words + shadow_word_at(list, base, px)] = word;
        }
        if (l.shadow_tints != 0ul) {
            ShadowTintsRef out_tints = ShadowTintsRef(l.shadow_tints);
            uint at = layer_tints + shadow_tint_at(px);
            for (uint s = 0u; s < SHADOW_TINT_SLOTS; ++s) out_tints.words[at + s] = tints[s];
        }
    }
#ifndef GLASS_LAYER
    if ((l.flags & SHADOW_DEBUG) != 0u) imageStore(shadow_debug_out, px, vec4(n * 0.5 + 0.5, float(rays)));
#endif
}

#endif
