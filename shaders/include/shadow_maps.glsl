// Shadow maps (render/src/shadows/maps.rs): an atlas of tiles, one per view (a spot light's, a
// point light's six cube faces, a directional light's fitted to the camera), each holding
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

// What reaches point p (normal n, `to_light` the unit direction towards the light) from the
// light in `slot`: 0 behind an opaque surface, the glass colour × (1 − opacity) behind glass,
// 1 in the open or without a map. Two texels are read, the point's and the one in the other row
// of its pair: the one with more opacity is the opaque surface, the other the glass (eq. 3.1).
// The point is moved off its surface by 1.5 texels along the normal and one towards the
// light (texels at its distance), against self-shadowing.
vec3 shadow_map_transmittance(uint slot, GpuLight light, vec3 p, vec3 n, vec3 to_light) {
    uint first = shadow_first_view(slot);
    if (first == NO_SHADOW_MAP) return vec3(1.0);
    uint v = light.kind == LIGHT_POINT ? first + cube_face(p - light.position) : first;
    GpuShadowView sv = shadow_view(v);
    float texel = sv.ortho != 0u ? sv.texel : sv.texel * distance(p, light.position);
    vec3 q = p + n * (1.5 * texel) + to_light * texel;
    vec4 clip = sv.view_proj * vec4(q, 1.0);
    if (clip.w <= 0.0) return vec3(1.0);
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return vec3(1.0);
    GpuLighting l = scene.lighting.lighting;
    int size = int(l.shadow_map_tile);
    ivec2 origin = ivec2(v % l.shadow_map_columns, v / l.shadow_map_columns) * size;
    ivec2 t = clamp(ivec2(vec2(0.5 + 0.5 * ndc.x, 0.5 - 0.5 * ndc.y) * float(size)), ivec2(0), ivec2(size - 1));
    ivec2 a = origin + t;
    ivec2 b = origin + ivec2(t.x, t.y ^ 1);
    float da = texelFetch(shadow_map_depth, a, 0).r;
    float db = texelFetch(shadow_map_depth, b, 0).r;
    vec4 fa = texelFetch(shadow_map_filter, a, 0);
    vec4 fb = texelFetch(shadow_map_filter, b, 0);
    bool a_is_glass = fa.a < fb.a;
    float opaque_depth = a_is_glass ? db : da;
    float glass_depth = a_is_glass ? da : db;
    vec4 glass = a_is_glass ? fa : fb;
    // Reverse-Z: a larger depth is nearer the light.
    if (opaque_depth > ndc.z) return vec3(0.0);
    if (glass.a < 1.0 && glass_depth > ndc.z) return glass.rgb * (1.0 - glass.a);
    return vec3(1.0);
}

#endif
