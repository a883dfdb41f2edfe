// What the ray-tracing-pipeline decal pass's shaders share: the payloads and the hit attribute.
#ifndef DECAL_PASS_GLSL
#define DECAL_PASS_GLSL

#include "decals.glsl"

// The surface and the per-channel sums (blend.glsl) travel with the ray.
struct DecalPayload {
    DecalBlend blend;
    DecalSurface surface;
    uint tested;   // decals tested (the debug views' count)
};

// The decals a pixel's first trace collects for its ray-generation shader to blend
// (decal_pass.rgen), in the payload of hit group DECAL_SBT_COLLECT. 136 bytes: the room for 32
// decals covers the pixels of every scatter up to a few tens of decals deep; a pixel with more
// is blended by a second trace through hit group DECAL_SBT_BLEND (DecalPayload).
#define DECAL_COLLECT_MAX 32u
#define DECAL_SBT_COLLECT 0
#define DECAL_SBT_BLEND 1
// The intersection shader's report (decal_pass.rint): the decal's slot, and where the point lies
// in its box with the fade there (fade < 0: a candidate only, reported for the debug views).
struct DecalHit {
    vec3 local;
    float fade;
    uint slot;
};

struct DecalCollect {
    uint tested;                      // any-hit invocations (the debug views' count)
    uint found;                       // decals found; those past DECAL_COLLECT_MAX are not kept
    uint slots[DECAL_COLLECT_MAX];    // the first ones found
};

// The debug views that count decals count every AABB candidate, as the ray-query loop does:
// the intersection shader then reports candidates outside their box too, with fade < 0.
bool counting_candidates() {
    return scene.debug_view == DEBUG_DECAL_COUNT || scene.debug_view == DEBUG_DECAL_HEATMAP;
}

#endif
