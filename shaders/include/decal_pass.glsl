// What the ray-tracing-pipeline decal pass's shaders share: the payloads and the hit attribute.
#ifndef DECAL_PASS_GLSL
#define DECAL_PASS_GLSL
#extension GL_EXT_control_flow_attributes : require

#include "decals.glsl"
#include "decal_lists.glsl"

// The surface and the per-channel sums (blend.glsl) travel with the ray.
struct DecalPayload {
    DecalBlend blend;
    DecalSurface surface;
    uint tested;   // decals tested (the debug views' count)
};

// The decals a reflection ray's first trace collects for its ray-generation shader to blend
// (blend_decals below), in the payload of the COLLECT any-hit shader. 136 bytes: the room for 32 decals
// covers the pixels of every scatter up to a few tens of decals deep; a pixel with more is
// blended by a second trace through the blending any-hit shader (DecalPayload).
#define DECAL_COLLECT_MAX 32u

// What the first trace of the on-screen pass carries (hit group DECAL_SBT_LIST): its any-hit
// shader writes the decals it finds to the pixel's list in memory (decal_lists.glsl), so the
// payload stays 16 bytes however many there are.
struct DecalListed {
    uint tested;   // any-hit invocations (the debug views' count)
    uint found;    // decals found; those past `room` are not written
    uint at;       // the list's first word in the list buffer (entry i: DECAL_LIST_RUN × i after it)
    uint room;     // decals the list has room for
};

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

// What a ray-generation shader that blends decals includes (decal_pass.rgen, and the reflection
// rays' hit points in reflections.glsl), after defining where its shader binding table keeps
// the blending hit group (DECAL_SBT_BLEND), the decal miss shader (DECAL_MISS) and the blending
// payload's location (DECAL_BLEND_LOCATION), and then how it collects decals: in the payload
// (DECAL_SBT_COLLECT and DECAL_COLLECT_LOCATION: the reflection rays, whose hit points change
// from frame to frame) or in the pixel's list in memory (DECAL_SBT_LIST and DECAL_LIST_LOCATION:
// the on-screen pass, decal_lists.glsl).
// A zero-length ray at surface view `s` through the scene's decal TLAS, then through the
// particles' decal ring's (each where there is one), into the payload at `location` with hit
// group `sbt`: the any-hit shaders accumulate into the payload, so the second trace adds to the
// first. The geometric normal travels as the ray's direction (the intersection shader's angle
// fade needs it). The loop stays a loop: lavapipe inlines every hit group's any-hit and
// intersection shaders at each traceRayEXT, so an unrolled one compiles all of them twice.
#define TRACE_DECALS(sbt, location, s) {                                                                                  \
        [[dont_unroll]] for (uint decal_structure = 0u; decal_structure < 2u; ++decal_structure) {                                      \
            uint64_t decal_tlas = decal_structure == 0u ? scene.decal_tlas : particle_decal_tlas();                     \
            if (decal_tlas == 0ul) continue;                                                                            \
            traceRayEXT(accelerationStructureEXT(decal_tlas), gl_RayFlagsNoOpaqueEXT | gl_RayFlagsSkipClosestHitShaderEXT, \
                        0xFF, sbt, 0, DECAL_MISS, s.position, 0.0, s.geometric_normal, 0.0, location);                   \
        }                                                                                                               \
    }

#ifdef DECAL_BLENDING_RAYGEN
layout(location = DECAL_BLEND_LOCATION) rayPayloadEXT DecalPayload decal_payload;

// The seed's way: a trace whose any-hit shader blends every decal at `s` into `b` (hit group
// DECAL_SBT_BLEND). Returns the decals tested.
uint blend_decals_in_any_hit(inout DecalBlend b, DecalSurface s) {
    decal_payload.blend = b;
    decal_payload.surface = s;
    decal_payload.tested = 0u;
    TRACE_DECALS(DECAL_SBT_BLEND, DECAL_BLEND_LOCATION, s);
    b = decal_payload.blend;
    return decal_payload.tested;
}

#ifdef DECAL_SBT_COLLECT
layout(location = DECAL_COLLECT_LOCATION) rayPayloadEXT DecalCollect decal_collected;

// The decals at surface view `s`, noted in `decal_collected` (tested and found). The geometric
// normal travels as the ray's direction: the intersection shader, which has no payload, needs
// it for the angle fade.
void collect_decals(DecalSurface s) {
    decal_collected.tested = 0u;
    decal_collected.found = 0u;
    TRACE_DECALS(DECAL_SBT_COLLECT, DECAL_COLLECT_LOCATION, s);
}

// Blends the decals at `s` into `b`; returns the decals tested. Unless `dense`,
// `decal_collected` holds what collect_decals found there, blended here when it kept them all.
// Otherwise (or when it found more than it kept) a trace blends them all in its any-hit shader.
uint blend_decals(inout DecalBlend b, DecalSurface s, bool dense) {
    if (!dense && decal_collected.found <= DECAL_COLLECT_MAX) {
        for (uint i = 0u; i < decal_collected.found; ++i) apply_decal(b, decal_collected.slots[i], s);
        return decal_collected.tested;
    }
    uint tested = blend_decals_in_any_hit(b, s);
    return dense ? tested : decal_collected.tested;
}
#endif

#ifdef DECAL_SBT_LIST
layout(location = DECAL_LIST_LOCATION) rayPayloadEXT DecalListed decal_listed;

// Blends the decals at `s` into `b` through a list with room for `room` decals from word `at`
// of the list buffer (one every DECAL_LIST_RUN words): a trace writes the decals it finds there (hit group DECAL_SBT_LIST), and
// they are tested, sampled and blended here, after it; when it found more than the room, a
// second trace blends them all in its any-hit shader (the caller sees it from `found` > `room`).
// Returns the decals tested; raises `found` to the decals found, when more.
uint list_and_blend_decals(inout DecalBlend b, DecalSurface s, uint at, uint room, inout uint found) {
    decal_listed = DecalListed(0u, 0u, at, room);
    TRACE_DECALS(DECAL_SBT_LIST, DECAL_LIST_LOCATION, s);
    uint n = decal_listed.found;
    found = max(found, n);
    if (n > room) {
        blend_decals_in_any_hit(b, s);
    } else {
        for (uint i = 0u; i < n; ++i) apply_decal(b, decal_lists().words[at + i * DECAL_LIST_RUN], s);
    }
    return decal_listed.tested;
}
#endif
#endif

#endif
