// variants: RAY_QUERY_COLLISION
#version 460
// Particle simulation (render/src/particles, particle_simulate.glsl): one invocation per pool
// slot, once the frame's opaque depth exists. A step ending behind the surface the depth buffer
// shows, by less than a thickness, crossed it; with RAY_QUERY_COLLISION (the ray-query tier,
// when the frame has the scene's structure) the step is a ray query against the scene instead.
// The living are appended to the drawn list, whose length is the indirect draw's instance
// count, with one atomic a subgroup.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "particles.glsl"
#include "depth_normals.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

#ifdef RAY_QUERY_COLLISION
#extension GL_EXT_ray_query : require
#include "particle_rays.glsl"

bool particle_contact(vec3 a, vec3 b, out vec3 hit, out vec3 n) {
    hit = b;
    n = vec3(0.0, 1.0, 0.0);
    float len = distance(a, b);
    if (len <= 0.0 || (in_front_of_depth(a) && in_front_of_depth(b))) return false;
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
// Where the step from `a` to `b` went behind the surface the depth buffer shows, if it did:
// the point where it crossed the surface's plane and the surface's normal. A step ending
// more than `thickness` metres behind the surface passed behind something, not into it.
bool depth_contact(vec3 a, vec3 b, float thickness, out vec3 hit, out vec3 n) {
    hit = b;
    n = vec3(0.0, 1.0, 0.0);
    GpuCamera cam = scene.camera.camera;
    vec4 clip = cam.view_proj * vec4(b, 1.0);
    if (clip.w <= 0.0) return false;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) return false;
    // The viewport is flipped: row 0 is NDC y = +1.
    ivec2 px = ivec2(vec2(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * cam.viewport_size);
    px = clamp(px, ivec2(0), ivec2(cam.viewport_size) - 1);
    float depth = depth_at(px);
    // Sky, or in front of the surface (reverse-Z: nearer is larger).
    if (depth <= 0.0 || ndc.z >= depth) return false;
    vec3 s = world_from_depth(vec2(px), depth);
    float behind = distance(cam.position, b) - distance(cam.position, s);
    if (behind > thickness) return false;
    n = normal_from_depth_improved(px, depth, s);
    float da = dot(a - s, n), db = dot(b - s, n);
    float t = da > db ? clamp(da / (da - db), 0.0, 1.0) : 1.0;
    hit = mix(a, b, t);
    // On the plane's front side, whatever rounding did.
    hit += n * max(0.0, -dot(hit - s, n));
    return true;
}

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
