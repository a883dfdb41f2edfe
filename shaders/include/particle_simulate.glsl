// Particle simulation (render/src/particles), shared by the compute pass (particles_simulate.comp:
// collision with the depth buffer, or with the scene's structure through ray queries) and the
// ray-generation pass of the ray-tracing-pipeline tier (particles_simulate.rgen). The including
// stage defines `particle_contact(a, b, hit, n)`: whether the step from a to b touched a surface,
// where and with what normal.
#ifndef PARTICLE_SIMULATE_GLSL
#define PARTICLE_SIMULATE_GLSL

#include "particles.glsl"

// Leaves emitter `e`'s decal where a particle landed: at `hit` on a surface of normal `n`, its
// box `decal_size` wide along the surface (turned about the normal by the particle's seed) and
// `decal_depth` across it, projecting into the surface, fading out over its last `decal_fade`
// seconds of `decal_lifetime` on the scene's clock. Written into the ring's next place (the
// oldest decal's), record and box: the decal passes find it through its box like any other.
void leave_decal(ParticleStateRef st, GpuEmitter e, vec3 hit, vec3 n, uint seed) {
    uint k = atomicAdd(st.state.decals_born, 1u) % max(st.state.decal_room, 1u);
    vec3 z = n;
    vec3 x0 = abs(z.y) < 0.9 ? normalize(cross(vec3(0.0, 1.0, 0.0), z)) : normalize(cross(vec3(1.0, 0.0, 0.0), z));
    float spin = 6.28318531 * random01(seed);
    vec3 x = x0 * cos(spin) + cross(z, x0) * sin(spin);
    vec3 y = cross(z, x);
    float s = max(e.decal_size, 1e-4), d = max(e.decal_depth, 1e-4);
    GpuDecal r;
    // World to decal: the box [-0.5, 0.5]³ around `hit`, local +Z along the normal.
    r.world_to_decal = mat4(vec4(x.x / s, y.x / s, z.x / d, 0.0), vec4(x.y / s, y.y / s, z.y / d, 0.0),
                            vec4(x.z / s, y.z / s, z.z / d, 0.0), vec4(-dot(x, hit) / s, -dot(y, hit) / s, -dot(z, hit) / d, 1.0));
    r.uv01 = vec4(0.0, 1.0, 1.0, 1.0);
    r.uv23 = vec4(1.0, 0.0, 0.0, 0.0);
    r.material_channel = e.decal_material;
    r.weight = 1.0;
    r.receivers = 0xFFFFFFFFu & ~DECAL_ON_SKIN;
    r.opacity = 1.0;
    r.angle_fade = packHalf2x16(vec2(0.0, 1.0));
    r.distance_fade = 0u;
    float end = scene.camera.camera.time + e.decal_lifetime;
    bool fades = e.decal_lifetime > 0.0;
    r.life_scale = fades ? -1.0 / max(e.decal_fade, 1e-3) : 0.0;
    r.life_offset = fades ? end / max(e.decal_fade, 1e-3) : 1.0;
    ParticleDecalsRef(st.state.decals).decals[k] = r;
    vec3 extent = 0.5 * (abs(x) * s + abs(y) * s + abs(z) * d);
    GpuAabb b;
    b.min = hit - extent;
    b.max = hit + extent;
    b.slot = GPU_DECAL | k;
    b.owner = 0u;
    ParticleDecalBoxesRef(st.state.decal_boxes).boxes[k] = b;
}

// Ages pool slot `i`, moves it a step and applies its emitter's contact rule; pushes it on the
// free list when it dies. Returns whether it is alive (to be drawn).
bool simulate_particle(ParticleStateRef st, uint i) {
    if (i >= st.state.capacity) return false;
    ParticlesRef pool = ParticlesRef(st.state.pool);
    GpuParticle p = pool.particles[i];
    if (p.lifetime <= 0.0) return false;
    float dt = st.state.delta;
    GpuEmitter e = particle_emitter(st, p.emitter);
    p.age += dt;
    bool alive = p.age < p.lifetime;
    if (alive && (p.flags & PARTICLE_STUCK) == 0u) {
        vec3 before = p.position;
        particle_step(p.position, p.velocity, e.acceleration, e.drag, dt);
        vec3 hit, n;
        if (e.contact != PARTICLE_CONTACT_NONE && st.state.collide != 0u && particle_contact(before, p.position, hit, n)) {
            if ((p.flags & PARTICLE_LANDED) == 0u) {
                atomicAdd(st.state.landed, 1u);
                if (e.decal_material != NO_DECAL && e.decal_size > 0.0) leave_decal(st, e, hit, n, p.seed);
            }
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
    return alive;
}

#endif
