// Shadow maps (render/src/shadows/maps.rs): an atlas of tiles, one per view (a spot light's, a
// point or area light's six cube faces, a directional light's fitted to the camera), each holding
// reverse-Z depth and, on odd rows, the colour and opacity of the glass nearest the light
// (seed 002 §3.2.1, Table 3.3). The views buffer (ScenePush::shadow_views): a header
// (SHADOW_VIEWS_HEADER words: the word offset of the views, their count), each light slot's
// first view (NO_SHADOW_MAP: none), then the GpuShadowViews.
#ifndef SHADOW_MAPS_GLSL
#define SHADOW_MAPS_GLSL

#include "scene.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer ShadowViewWordsRef { uint words[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ShadowViewsRef { GpuShadowView views[]; };

GpuShadowView shadow_view(uint v) {
    uint64_t base = scene.shadow_views;
    uint offset = ShadowViewWordsRef(base).words[0];
    return ShadowViewsRef(base + uint64_t(offset) * 4ul).views[v];
}

// The first view of light `slot` (NO_SHADOW_MAP: it has none).
uint shadow_first_view(uint slot) {
    return ShadowViewWordsRef(scene.shadow_views).words[SHADOW_VIEWS_HEADER + slot];
}

// The cube face of a point light that sees `d` (from the light): +X, −X, +Y, −Y, +Z, −Z.
uint cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

// Whether `light` has a cube of six views (render/src/shadows/maps.rs, is_cube): point lights,
// and area lights from their centre.
bool cube_mapped(GpuLight light) {
    return light.kind == LIGHT_POINT || light.kind == LIGHT_RECT || light.kind == LIGHT_DISK;
}

// The view of light `slot` (whose first view is `first`) that sees world point `x`.
uint shadow_view_of(uint first, GpuLight light, vec3 x) {
    return cube_mapped(light) ? first + cube_face(x - light.position) : first;
}

// Texel `t` of view `v`'s tile and the one in the other row of its pair: the opaque surface's
// depth (the texel with more opacity), the glass's depth and its colour and opacity (eq. 3.1).
void shadow_map_texels(uint v, ivec2 t, out float opaque_depth, out float glass_depth, out vec4 glass) {
    GpuLighting l = scene.lighting.lighting;
    ivec2 origin = ivec2(v % l.shadow_map_columns, v / l.shadow_map_columns) * int(l.shadow_map_tile);
    ivec2 a = origin + t;
    ivec2 b = origin + ivec2(t.x, t.y ^ 1);
    float da = texelFetch(shadow_map_depth, a, 0).r;
    float db = texelFetch(shadow_map_depth, b, 0).r;
    vec4 fa = texelFetch(shadow_map_filter, a, 0);
    vec4 fb = texelFetch(shadow_map_filter, b, 0);
    bool a_is_glass = fa.a < fb.a;
    opaque_depth = a_is_glass ? db : da;
    glass_depth = a_is_glass ? da : db;
    glass = a_is_glass ? fa : fb;
}

// World point `x` in view `v`: its tile texel and reverse-Z depth; false outside the view.
bool shadow_map_locate(uint v, vec3 x, out ivec2 t, out float depth) {
    GpuShadowView sv = shadow_view(v);
    vec4 clip = sv.view_proj * vec4(x, 1.0);
    if (clip.w <= 0.0) return false;
    vec3 ndc = clip.xyz / clip.w;
    // Outside the map: beside it, nearer the light than its near plane, or beyond its far one.
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0 || ndc.z < 0.0) return false;
    int size = int(scene.lighting.lighting.shadow_map_tile);
    t = clamp(ivec2(vec2(0.5 + 0.5 * ndc.x, 0.5 - 0.5 * ndc.y) * float(size)), ivec2(0), ivec2(size - 1));
    depth = ndc.z;
    return true;
}

// Point p (normal n, `to_light` the unit direction towards the light's centre) moved off its
// surface by 1.5 texels along the normal and one towards the light (texels at its distance),
// against self-shadowing; the view that sees it in `v`.
vec3 shadow_map_point(uint first, GpuLight light, vec3 p, vec3 n, vec3 to_light, out uint v) {
    v = shadow_view_of(first, light, p);
    GpuShadowView sv = shadow_view(v);
    float texel = sv.ortho != 0u ? sv.texel : sv.texel * distance(p, light.position);
    return p + n * (1.5 * texel) + to_light * texel;
}

// What reaches point p (normal n, `to_light` the unit direction towards the light) from the
// light in `slot`: 0 behind an opaque surface, the glass colour × (1 − opacity) behind glass,
// 1 in the open or without a map. Two texels are read, the point's and the one in the other row
// of its pair: the one with more opacity is the opaque surface, the other the glass (eq. 3.1).
vec3 shadow_map_transmittance(uint slot, GpuLight light, vec3 p, vec3 n, vec3 to_light) {
    uint first = shadow_first_view(slot);
    if (first == NO_SHADOW_MAP) return vec3(1.0);
    uint v;
    vec3 q = shadow_map_point(first, light, p, n, to_light, v);
    ivec2 t;
    float depth, opaque_depth, glass_depth;
    vec4 glass;
    if (!shadow_map_locate(v, q, t, depth)) return vec3(1.0);
    shadow_map_texels(v, t, opaque_depth, glass_depth, glass);
    // Reverse-Z: a larger depth is nearer the light.
    if (opaque_depth > depth) return vec3(0.0);
    if (glass.a < 1.0 && glass_depth > depth) return glass.rgb * (1.0 - glass.a);
    return vec3(1.0);
}

// Steps of a sampled shadow-map ray (shadow_map_transmittance_sampled).
#define SHADOW_MAP_RAY_STEPS 16
// A directional light's ray that strays less than two texels across its map over this many
// metres takes the hard lookup: its penumbra would be finer than the map resolves (the real
// sun's 0.53° strays under half a texel over 10 m of a map of 10 cm texels).
#define SHADOW_MAP_SOFT_REACH 10.0

// The light in `slot` seen from p along `dir`, towards a point of the light's shape `tmax`
// away (shadow_ray_sampled; `to_centre` towards the light's centre): the segment is marched
// through the light's maps, each step looked up in the view that sees it, and it is blocked
// where a step lies behind the opaque surface the map holds there by less than the depth change
// to the next step (the segment crosses that surface before it: a step far behind it lies in
// the shadow of what the light's centre sees without touching it, as the inner penumbra does),
// or where the last step is still behind a surface (it has not left that shadow). The first
// step is the point as the hard lookup moves it off its surface (against self-shadowing), the
// next start from the point lifted half a texel and advance by `jitter` (0..1, per pixel and
// frame) of a step, so that temporal anti-aliasing averages the gaps away. Towards a sphere or
// spot light the steps are spaced evenly up to the light; towards a directional light (whose
// map is as deep as the shadows reach) each moves the ray at most a texel across the map,
// 2 × SHADOW_MAP_RAY_STEPS of them: occluders beyond that drift take the centre's answer (the
// last step still behind one). A ray of a sun that strays less than two texels across the map
// over SHADOW_MAP_SOFT_REACH takes the hard lookup. Glass in front of the point tints what gets
// through, as for a hard shadow.
vec3 shadow_map_transmittance_sampled(uint slot, GpuLight light, vec3 p, vec3 n, vec3 to_centre, vec3 dir, float tmax, float jitter) {
    uint first = shadow_first_view(slot);
    if (first == NO_SHADOW_MAP) return vec3(1.0);
    uint v;
    vec3 moved = shadow_map_point(first, light, p, n, to_centre, v);
    GpuShadowView sv = shadow_view(v);
    vec3 q = p + n * (0.5 * (sv.ortho != 0u ? sv.texel : sv.texel * distance(p, light.position)));
    float span = tmax;
    int steps = SHADOW_MAP_RAY_STEPS;
    if (light.kind == LIGHT_DIRECTIONAL) {
        // To where the map's depth reaches its near plane (1) along the ray, at most a texel
        // across the map a step.
        float z0 = (sv.view_proj * vec4(q, 1.0)).z;
        vec4 along = sv.view_proj * vec4(dir, 0.0);
        span = along.z > 0.0 ? (1.0 - z0) / along.z : 0.0;
        float texels = length(along.xy) * 0.5 * float(scene.lighting.lighting.shadow_map_tile);
        if (texels * min(span, SHADOW_MAP_SOFT_REACH) < 2.0) return shadow_map_transmittance(slot, light, p, n, to_centre);
        steps = 2 * SHADOW_MAP_RAY_STEPS;
        span = min(span, float(steps) / texels);
    }
    vec3 glass = vec3(1.0);
    vec3 step = dir * (span / float(steps));
    bool behind = false;
    for (int i = 0; i <= steps; ++i) {
        vec3 x = i == 0 ? moved : q + step * (float(i - 1) + jitter);
        vec3 next = q + step * (float(i) + jitter);
        uint vx = shadow_view_of(first, light, x);
        ivec2 t;
        float depth, opaque_depth, glass_depth;
        vec4 glass_texel;
        behind = false;
        if (!shadow_map_locate(vx, x, t, depth)) continue;
        shadow_map_texels(vx, t, opaque_depth, glass_depth, glass_texel);
        if (i == 0 && glass_texel.a < 1.0 && glass_depth > depth) glass = glass_texel.rgb * (1.0 - glass_texel.a);
        // The depth change to the next step in this view (reverse-Z: towards the light it
        // grows, and faster nearer the light).
        vec4 ahead = shadow_view(vx).view_proj * vec4(next, 1.0);
        float thickness = ahead.w > 0.0 ? abs(ahead.z / ahead.w - depth) : 0.0;
        behind = opaque_depth > depth;
        if (behind && opaque_depth - depth <= thickness) return vec3(0.0);
    }
    return behind ? vec3(0.0) : glass;
}

#endif
