// What the ray-tracing-pipeline decal pass's shaders share: the payload and the hit attribute.
#ifndef DECAL_PASS_GLSL
#define DECAL_PASS_GLSL

#include "decals.glsl"

// The surface and the per-channel sums (blend.glsl) travel with the ray.
struct DecalPayload {
    DecalBlend blend;
    DecalSurface surface;
    uint tested;   // decals tested (the debug views' count)
};

// The debug views that count decals count every AABB candidate, as the ray-query loop does:
// the intersection shader then reports candidates outside their box too, with fade < 0.
bool counting_candidates() {
    return scene.debug_view == DEBUG_DECAL_COUNT || scene.debug_view == DEBUG_DECAL_HEATMAP;
}

#endif
