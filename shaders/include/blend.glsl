// Per-channel weighted blended OIT for decals (seed 000 §4.3.1, Listing 4.2), then alpha
// blending from channel 0 to channel 3. For each channel and attribute:
//   sum   = Σ value · a · w      (numerator)
//   vis   = Π (1 − a)            (how much of the background remains)
//   wsum  = Σ a · w              (denominator)
//   result = sum / wsum · (1 − vis) + background · vis
// The seed shares one weight between roughness and metallic; we keep them apart so a decal that
// sets only roughness does not drag metallic towards zero. tests/tests/decal_blend.rs evaluates
// the same equations on the CPU.
#ifndef BLEND_GLSL
#define BLEND_GLSL

#include "layout.glsl"  // DECAL_CHANNELS

struct DecalBlend {
    vec4 albedo[DECAL_CHANNELS];   // rgb: Σ albedo·a·w,  a: Π(1−a)
    vec4 normal[DECAL_CHANNELS];   // xyz: Σ n·a·w,       w: Π(1−a)
    vec4 spec[DECAL_CHANNELS];     // xy: Σ (roughness, metallic)·a·w,  zw: Π(1−a) of each
    vec4 weight[DECAL_CHANNELS];   // Σ a·w for albedo, normal, roughness, metallic
};

void blend_init(out DecalBlend b) {
    for (uint c = 0u; c < DECAL_CHANNELS; ++c) {
        b.albedo[c] = vec4(0.0, 0.0, 0.0, 1.0);
        b.normal[c] = vec4(0.0, 0.0, 0.0, 1.0);
        b.spec[c] = vec4(0.0, 0.0, 1.0, 1.0);
        b.weight[c] = vec4(0.0);
    }
}

void blend_albedo(inout DecalBlend b, uint c, vec3 value, float a, float w) {
    b.albedo[c].rgb += value * a * w;
    b.albedo[c].a *= 1.0 - a;
    b.weight[c].x += a * w;
}

void blend_normal(inout DecalBlend b, uint c, vec3 n, float a, float w) {
    b.normal[c].xyz += n * a * w;
    b.normal[c].w *= 1.0 - a;
    b.weight[c].y += a * w;
}

void blend_roughness(inout DecalBlend b, uint c, float value, float a, float w) {
    b.spec[c].x += value * a * w;
    b.spec[c].z *= 1.0 - a;
    b.weight[c].z += a * w;
}

void blend_metallic(inout DecalBlend b, uint c, float value, float a, float w) {
    b.spec[c].y += value * a * w;
    b.spec[c].w *= 1.0 - a;
    b.weight[c].w += a * w;
}

// Composites the channels over the surface attributes, channel 0 first.
void blend_resolve(DecalBlend b, inout vec3 albedo, inout vec3 n, inout float roughness, inout float metallic) {
    for (uint c = 0u; c < DECAL_CHANNELS; ++c) {
        vec4 w = b.weight[c];
        if (w.x > 0.0) albedo = b.albedo[c].rgb / w.x * (1.0 - b.albedo[c].a) + albedo * b.albedo[c].a;
        if (w.y > 0.0) n = b.normal[c].xyz / w.y * (1.0 - b.normal[c].w) + n * b.normal[c].w;
        if (w.z > 0.0) roughness = b.spec[c].x / w.z * (1.0 - b.spec[c].z) + roughness * b.spec[c].z;
        if (w.w > 0.0) metallic = b.spec[c].y / w.w * (1.0 - b.spec[c].w) + metallic * b.spec[c].w;
    }
    float len2 = dot(n, n);
    n = len2 > 1e-12 ? n * inversesqrt(len2) : n;
}

#endif
