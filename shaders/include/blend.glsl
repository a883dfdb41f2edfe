// Per-channel weighted blended OIT for decals (seed 000 §4.3.1, Listing 4.2), then alpha
// blending from channel 0 to channel 3. For each channel and attribute:
//   sum   = Σ value · a · w      (numerator)
//   vis   = Π (1 − a)            (how much of the background remains)
//   wsum  = Σ a · w              (denominator)
//   result = sum / wsum · (1 − vis) + background · vis
// The seed shares one weight between roughness and metallic; we keep them apart so a decal that
// sets only roughness does not drag metallic towards zero. tests/tests/decal_blend.rs evaluates
// the same equations on the CPU.
// Emission (the fifth attribute, which the seed's decals lack) is light, not a property of the
// surface: decals add it, Σ emission · a over every decal whatever its channel, as emissive
// decals add to the lit image in Unreal's and HDRP's deferred decals. A sum is
// order-independent by itself, and it needs no weights, so it costs the blend state one vec3.
#ifndef BLEND_GLSL
#define BLEND_GLSL

#include "layout.glsl"  // DECAL_CHANNELS

// A shader that defines DECAL_BLEND_ONE_CHANNEL before including this keeps the sums of one
// channel at a time (BLEND_SLOTS = 1): it must blend one channel's decals, fold them into a
// DecalComposite (blend_collapse_onto), and go on with the next channel, in order. The result
// is the same arithmetic; the state is a quarter of the size, which is what a forward shading
// pass that walks decal lists can afford (shading.glsl, CLUSTERED_DECALS).
#ifdef DECAL_BLEND_ONE_CHANNEL
#define BLEND_SLOTS 1u
#else
#define BLEND_SLOTS DECAL_CHANNELS
#endif

struct DecalBlend {
    vec4 albedo[BLEND_SLOTS];   // rgb: Σ albedo·a·w,  a: Π(1−a)
    vec4 normal[BLEND_SLOTS];   // xyz: Σ n·a·w,       w: Π(1−a)
    vec4 spec[BLEND_SLOTS];     // xy: Σ (roughness, metallic)·a·w,  zw: Π(1−a) of each
    vec4 weight[BLEND_SLOTS];   // Σ a·w for albedo, normal, roughness, metallic
    vec3 emissive;              // Σ emission·a over every channel
};

void blend_init(out DecalBlend b) {
    for (uint c = 0u; c < BLEND_SLOTS; ++c) {
        b.albedo[c] = vec4(0.0, 0.0, 0.0, 1.0);
        b.normal[c] = vec4(0.0, 0.0, 0.0, 1.0);
        b.spec[c] = vec4(0.0, 0.0, 1.0, 1.0);
        b.weight[c] = vec4(0.0);
    }
    b.emissive = vec3(0.0);
}

// Runs STEP(slot) for a channel's slot with the slot a constant in every branch. A slot picked
// by a runtime index makes the compiler keep the arrays in addressable memory, where the decal
// pass's any-hit shader then reads and writes them for every decal: measured on the lent H100
// (docs/BENCHMARKS.md, "The ray-tracing-pipeline decal pass against its floor"), constant slots
// made that pass 13-15 % faster and the clustered pass 9-10 %.
#ifdef DECAL_BLEND_ONE_CHANNEL
#define BLEND_AT_SLOT(channel, STEP) STEP(0)
#else
#define BLEND_AT_SLOT(channel, STEP) \
    switch (channel) { \
    case 0u: STEP(0) break; \
    case 1u: STEP(1) break; \
    case 2u: STEP(2) break; \
    default: STEP(3) break; \
    }
#endif

#define BLEND_ALBEDO_STEP(c) b.albedo[c].rgb += value * a * w; b.albedo[c].a *= 1.0 - a; b.weight[c].x += a * w;
#define BLEND_NORMAL_STEP(c) b.normal[c].xyz += n * a * w; b.normal[c].w *= 1.0 - a; b.weight[c].y += a * w;
#define BLEND_ROUGHNESS_STEP(c) b.spec[c].x += value * a * w; b.spec[c].z *= 1.0 - a; b.weight[c].z += a * w;
#define BLEND_METALLIC_STEP(c) b.spec[c].y += value * a * w; b.spec[c].w *= 1.0 - a; b.weight[c].w += a * w;

void blend_albedo(inout DecalBlend b, uint channel, vec3 value, float a, float w) {
    BLEND_AT_SLOT(channel, BLEND_ALBEDO_STEP)
}

void blend_normal(inout DecalBlend b, uint channel, vec3 n, float a, float w) {
    BLEND_AT_SLOT(channel, BLEND_NORMAL_STEP)
}

void blend_roughness(inout DecalBlend b, uint channel, float value, float a, float w) {
    BLEND_AT_SLOT(channel, BLEND_ROUGHNESS_STEP)
}

void blend_emissive(inout DecalBlend b, vec3 radiance, float a) {
    b.emissive += radiance * a;
}

void blend_metallic(inout DecalBlend b, uint channel, float value, float a, float w) {
    BLEND_AT_SLOT(channel, BLEND_METALLIC_STEP)
}

// The channels composited in order (channel 0 first) collapse into one affine map per
// attribute, `value = decal + value × remaining` (the seed's final step): a channel maps v to
// A_c + v·R_c with A_c = sum/wsum·(1 − vis) and R_c = vis, and the composition of affine maps
// is affine. The decal buffer stores exactly this, so passes that apply decals later (the
// shading passes reading a decal pass's output) get the same result as blend_resolve.
struct DecalComposite {
    vec4 albedo;   // rgb: decal albedo, a: weight remaining to the surface's albedo
    vec4 normal;   // xyz: decal normal, w: remaining
    vec4 spec;     // xy: decal roughness and metallic, zw: remaining
    vec3 emissive; // radiance the decals add to the surface's emission
};

// The composite that leaves the surface as it is.
DecalComposite blend_identity() {
    DecalComposite o;
    o.albedo = vec4(0.0, 0.0, 0.0, 1.0);
    o.normal = vec4(0.0, 0.0, 0.0, 1.0);
    o.spec = vec4(0.0, 0.0, 1.0, 1.0);
    o.emissive = vec3(0.0);
    return o;
}

// Composites the channels of `b` over `o` (what the channels before them made), in order.
void blend_collapse_onto(inout DecalComposite o, DecalBlend b) {
    o.emissive += b.emissive;
    for (uint c = 0u; c < BLEND_SLOTS; ++c) {
        vec4 w = b.weight[c];
        if (w.x > 0.0) o.albedo = vec4(b.albedo[c].rgb / w.x * (1.0 - b.albedo[c].a) + o.albedo.rgb * b.albedo[c].a, o.albedo.a * b.albedo[c].a);
        if (w.y > 0.0) o.normal = vec4(b.normal[c].xyz / w.y * (1.0 - b.normal[c].w) + o.normal.xyz * b.normal[c].w, o.normal.w * b.normal[c].w);
        if (w.z > 0.0) { o.spec.x = b.spec[c].x / w.z * (1.0 - b.spec[c].z) + o.spec.x * b.spec[c].z; o.spec.z *= b.spec[c].z; }
        if (w.w > 0.0) { o.spec.y = b.spec[c].y / w.w * (1.0 - b.spec[c].w) + o.spec.y * b.spec[c].w; o.spec.w *= b.spec[c].w; }
    }
}

DecalComposite blend_collapse(DecalBlend b) {
    DecalComposite o = blend_identity();
    blend_collapse_onto(o, b);
    return o;
}

// Applies a collapsed composite to the surface attributes (then renormalises the normal).
void blend_apply(DecalComposite o, inout vec3 albedo, inout vec3 n, inout float roughness, inout float metallic, inout vec3 emissive) {
    emissive += o.emissive;
    albedo = o.albedo.rgb + albedo * o.albedo.a;
    n = o.normal.xyz + n * o.normal.w;
    roughness = o.spec.x + roughness * o.spec.z;
    metallic = o.spec.y + metallic * o.spec.w;
    float len2 = dot(n, n);
    n = len2 > 1e-12 ? n * inversesqrt(len2) : n;
}

// Composites the channels over the surface attributes, channel 0 first.
void blend_resolve(DecalBlend b, inout vec3 albedo, inout vec3 n, inout float roughness, inout float metallic, inout vec3 emissive) {
    blend_apply(blend_collapse(b), albedo, n, roughness, metallic, emissive);
}

#endif
