// Particle simulation (render/src/particles), shared by the compute pass (particles_simulate.comp:
// collision with the depth buffer, or with the scene's structure through ray queries) and the
// ray-generation pass of the ray-tracing-pipeline tier (particles_simulate.rgen). The including
// stage defines `particle_contact(a, b, hit, n)`: whether the step from a to b touched a surface,
// where and with what normal.
#ifndef PARTICLE_SIMULATE_GLSL
#define PARTICLE_SIMULATE_GLSL

#include "particles.glsl"

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
    return alive;
}

#endif
