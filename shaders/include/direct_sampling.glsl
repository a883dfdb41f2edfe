// Stochastic direct lighting's shadows (render/src/lights/sampling): instead of a shadow ray
// towards every light of its list (seed 001 §4.3), a pixel whose list holds more than
// GpuLighting::sampled_lights_above lights draws one of them (of at most DIRECT_LIGHT_CANDIDATES
// candidates) in proportion to its unshadowed light (through the whole BRDF where the pass has
// the material, on a diffuse surface otherwise: unshadowed_weight; weighted reservoir
// sampling, as ReSTIR streams its candidates: Bitterli et al. 2020 §3), and one shadow ray goes
// to a point of that light's shape. The ray's
// visibility V, with the pixel's whole unshadowed light S (weighed alike), makes the
// ratio estimator of Heitz et al. 2018 (I3D, "Combining analytic direct illumination and
// stochastic shadows"): the denoiser averages V weighted by S over neighbours on the same surface,
// and shading multiplies the exact unshadowed sum of the pixel's lights by that ratio, so what is
// unshadowed stays free of noise. Shared by the shadow pass (which samples) and shading (which
// must make the same choice of pixels).
#ifndef DIRECT_SAMPLING_GLSL
#define DIRECT_SAMPLING_GLSL

#include "color.glsl"
#include "random.glsl"
#include "lighting.glsl"
#include "light_tiles.glsl"

// log2 of the estimate S, exactly this: the pixel sampled nothing (no candidate reached it, or
// its list was exhaustive); a sampling pixel's is above it.
const float SAMPLED_NONE = -120.0;

// Whether the pixel with light list `list` samples its lights' shadows (the shadow pass and
// shading agree on it; a list without shadow rows is unshadowed either way).
bool samples_lights(LightList list) {
    return list.rows != NO_SHADOW_ROWS && list.count > scene.lighting.lighting.sampled_lights_above;
}

// What resampling a pixel's list gives: the slot of the light its shadow ray goes to (NO_SLOT:
// none reaches the point), and S, the list's whole unshadowed light as unshadowed_weight weighs
// it (its estimate from the candidates, for long lists).
struct LightSample {
    uint slot;
    float estimate;
};
const uint NO_SLOT = 0xFFFFFFFFu;

// The directional lights a sampling pixel traces a ray to each, rather than sampling them with
// the rest (GpuLighting::suns): a sun is in every list and often the strongest light, so drawn
// with the others it would be found by few pixels and light them brightly (noise no small
// neighbourhood averages out). Read once before a loop over lights, or, in a loop whose
// registers are scarce (shading.glsl's), where a directional light needs it.
struct Suns {
    uint count;
    uvec4 slots;
};

Suns sampling_suns() {
    uint count = scene.lighting.lighting.sun_count;
    uint s[4] = scene.lighting.lighting.suns;
    return Suns(count, uvec4(s[0], s[1], s[2], s[3]));
}

// Which of `suns` light slot `slot` is (-1: none).
int sun_index(Suns suns, uint slot) {
    for (uint k = 0u; k < 4u; ++k) {
        if (k < suns.count && suns.slots[k] == slot) return int(k);
    }
    return -1;
}

// The point a pixel draws its lights for: where it is, its normal and, where the pass has the
// material (SHADOW_MATERIAL: the deferred pipeline's G-buffer), the direction to the eye and the
// surface's BRDF.
struct DrawPoint {
    vec3 p;
    vec3 n;
#ifdef SHADOW_MATERIAL
    vec3 v;
    SurfaceBrdf brdf;
#endif
};

// The target function resampling draws in proportion to: the luminance of the light `light`
// reflects at `at`, unshadowed (zero where it cannot reach). Through the whole BRDF, specular
// lobe included, where the material is known (SHADOW_MATERIAL); otherwise the light a diffuse
// surface receives. Shading multiplies its exact unshadowed sum by the ratio the draws estimate,
// which is exact on average only when the draws weigh each light by its share of that sum: a
// glossy floor's highlight is most of it, and the diffuse weight does not see it.
float unshadowed_weight(GpuLight light, DrawPoint at) {
    vec3 l;
    vec3 incident = light_incidence(light, at.p, l);
#ifdef SHADOW_MATERIAL
    return luminance(brdf_cos(at.brdf, at.n, at.v, l) * incident);
#else
    return luminance(incident) * max(dot(at.n, l), 0.0);
#endif
}

// Draws one light of `list` for point `p` (normal `n`) in proportion to its unshadowed light, by
// weighted reservoir sampling (one pass, one uniform number a light that reaches the point).
// Lists of up to DIRECT_LIGHT_CANDIDATES lights are drawn from whole: the proportions are exact
// and S is the list's unshadowed light itself, so the visibility V of one draw is an unbiased
// estimate of the share that gets through, and so are its averages over neighbours and frames.
// Longer lists give one candidate from each of DIRECT_LIGHT_CANDIDATES equal strata (a shared
// random offset: systematic sampling, so every light is visited over frames where the draws
// change), weighted by the
// stratum's length: S is then an unbiased estimate, and V a ratio of two random sums, biased dark
// by a share that shrinks as the candidates grow (with eight candidates a test pixel whose lights
// were 2 % shadowed came out 27 % too dark).
LightSample draw_light(LightList list, DrawPoint at, inout uint seed) {
    uint m = min(list.count, DIRECT_LIGHT_CANDIDATES);
    float stratum = float(list.count) / float(m);
    float offset = m < list.count ? random01(seed) : 0.0;
    LightSample chosen = LightSample(NO_SLOT, 0.0);
    Suns suns = sampling_suns();
    for (uint i = 0u; i < m; ++i) {
        uint j = min(uint((float(i) + offset) * stratum), list.count - 1u);
        uint slot = light_slot(list, j);
        GpuLight light = scene.lights.lights[slot];
        if (light.kind == LIGHT_DIRECTIONAL && sun_index(suns, slot) >= 0) continue;
        float w = unshadowed_weight(light, at) * stratum;
        if (!(w > 0.0)) continue;
        chosen.estimate += w;
        if (random01(seed) * chosen.estimate <= w) chosen.slot = slot;
    }
    return chosen;
}

// The seed of pixel `px`'s draw: new every frame where lights are tiled (the frame count light
// culling keeps, LSTAT_FRAME), so that temporal anti-aliasing's history, or any average over
// frames, averages the draws; with every-light lists, new every frame where temporal
// anti-aliasing counts frames (GpuCamera::taa_frame), fixed without it.
uint light_draw_seed(ivec2 px) {
    uint frame = scene.lighting.lighting.mode == LIGHTS_TILED ? light_tile_words().words[LSTAT_FRAME] : scene.camera.camera.taa_frame;
    return pcg_hash(uint(px.x) * 2654435761u ^ uint(px.y) * 40503u ^ pcg_hash(frame));
}

#endif
