// variants: RAY_QUERY_COLLISION
#version 460
// Particle simulation (render/src/particles, particle_simulate.glsl): one invocation per pool
// slot, once the frame's opaque depth exists. A step ending behind the surface the depth buffer
// shows, by less than a thickness, crossed it (particle_depth.glsl); with RAY_QUERY_COLLISION
// (the ray-query tier, when the frame has the scene's structure) the steps the depth buffer
// cannot answer are ray queries against the scene (particle_rays.glsl).
// The living are appended to the drawn list, whose length is the indirect draw's instance
// count, with one atomic a subgroup.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "particles.glsl"
#include "particle_depth.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

#ifdef RAY_QUERY_COLLISION
#extension GL_EXT_ray_query : require
#include "particle_rays.glsl"

bool particle_contact(vec3 a, vec3 b, out vec3 hit, out vec3 n) {
    hit = b;
    n = vec3(0.0, 1.0, 0.0);
    float len = distance(a, b);
    if (len <= 0.0) return false;
    bool contact;
    if (depth_answers(a, b, contact, hit, n)) return contact;
    vec3 dir = (b - a) / len;
    rayQueryEXT q;
    rayQueryInitializeEXT(q, accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsOpaqueEXT, 0xFF, a, 0.0, dir, len);
    while (rayQueryProceedEXT(q)) {}
    if (rayQueryGetIntersectionTypeEXT(q, true) != gl_RayQueryCommittedIntersectionTriangleEXT) return false;
    ray_contact(rayQueryGetIntersectionInstanceCustomIndexEXT(q, true), rayQueryGetIntersectionPrimitiveIndexEXT(q, true), a, dir,
                rayQueryGetIntersectionTEXT(q, true), hit, n);
    return true;
}
#else
bool particle_contact(vec3 a, vec3 b, out vec3 hit, out vec3 n) {
    return depth_contact(a, b, max(0.1, 2.0 * distance(a, b)), hit, n);
}
#endif

#include "particle_simulate.glsl"

void main() {
    ParticleStateRef st = particle_state();
    uint i = gl_GlobalInvocationID.x;
    bool alive = simulate_particle(st, i);
    // The living, appended to the drawn list: one atomic a subgroup.
    uvec4 ballot = subgroupBallot(alive);
    uint count = subgroupBallotBitCount(ballot);
    uint base = 0u;
    if (count > 0u && subgroupElect()) base = atomicAdd(st.state.draw[1], count);
    base = subgroupBroadcastFirst(base);
    if (alive) ParticleSlotsRef(st.state.alive_list).slots[base + subgroupBallotExclusiveBitCount(ballot)] = i;
}
