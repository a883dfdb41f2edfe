#version 460
// Particle simulation (render/src/particles): one invocation per pool slot, once the frame's
// opaque depth exists. A living particle ages, takes a step (particles.glsl), and collides with
// the surface the depth buffer shows: a step ending behind the visible surface by less than a
// thickness crossed it, and its emitter says whether it then dies, bounces or sticks. The dead
// go back on the free list; the living are appended to the drawn list, whose length is the
// indirect draw's instance count.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "particles.glsl"
#include "depth_normals.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

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

void main() {
    ParticleStateRef st = particle_state();
    ParticlesRef pool = ParticlesRef(st.state.pool);
    uint i = gl_GlobalInvocationID.x;
    bool alive = false;
    if (i < st.state.capacity) {
        GpuParticle p = pool.particles[i];
        if (p.lifetime > 0.0) {
            float dt = st.state.delta;
            GpuEmitter e = particle_emitter(st, p.emitter);
            p.age += dt;
            alive = p.age < p.lifetime;
            if (alive && (p.flags & PARTICLE_STUCK) == 0u) {
                vec3 before = p.position;
                particle_step(p.position, p.velocity, e.acceleration, e.drag, dt);
                vec3 hit, n;
                float thickness = max(0.1, 2.0 * distance(before, p.position));
                if (e.contact != PARTICLE_CONTACT_NONE && st.state.depth_collision != 0u
                    && depth_contact(before, p.position, thickness, hit, n)) {
                    if ((p.flags & PARTICLE_LANDED) == 0u) atomicAdd(st.state.landed, 1u);
                    p.flags |= PARTICLE_LANDED;
                    p.contact_normal = pack_normal(n);
                    // Lifted 2 mm off the surface, so that the next step starts in front of it.
                    p.position = hit + n * 0.002;
                    if (e.contact == PARTICLE_CONTACT_DIE) {
                        alive = false;
                    } else if (e.contact == PARTICLE_CONTACT_STICK) {
                        p.velocity = vec3(0.0);
                        p.flags |= PARTICLE_STUCK;
                    } else {
                        float vn = dot(p.velocity, n);
                        vec3 along = p.velocity - vn * n;
                        p.velocity = along * e.friction - min(vn, 0.0) * e.restitution * n + max(vn, 0.0) * n;
                    }
                }
            }
            if (alive) {
                pool.particles[i] = p;
            } else {
                pool.particles[i].lifetime = 0.0;
                uint at = atomicAdd(st.state.free_count, 1u);
                ParticleSlotsRef(st.state.free_list).slots[at] = i;
            }
        }
    }
    // The living, appended to the drawn list: one atomic a subgroup.
    uvec4 ballot = subgroupBallot(alive);
    uint count = subgroupBallotBitCount(ballot);
    uint base = 0u;
    if (count > 0u && subgroupElect()) base = atomicAdd(st.state.draw[1], count);
    base = subgroupBroadcastFirst(base);
    if (alive) ParticleSlotsRef(st.state.alive_list).slots[base + subgroupBallotExclusiveBitCount(ballot)] = i;
}
