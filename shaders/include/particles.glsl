// GPU particles (render/src/particles): the state, the pool, the free and drawn lists and the
// emitters as every particle pass sees them, the random numbers, and the motion step the CPU
// repeats as its reference (render/src/particles/emitters.rs, `step`).
#ifndef PARTICLES_GLSL
#define PARTICLES_GLSL

#include "scene.glsl"
#include "random.glsl"

// The state buffer: the frame's record (CPU-written), the counters (GPU-written), the jobs.
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ParticleStateRef {
    GpuParticleState state;
    GpuEmission jobs[];
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ParticlesRef { GpuParticle particles[]; };
// The free list and the drawn list: pool slots.
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ParticleSlotsRef { uint slots[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer EmittersRef { GpuEmitter emitters[]; };
// The decal ring (GPU-born decals): records and their boxes.
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ParticleDecalsRef { GpuDecal decals[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ParticleDecalBoxesRef { GpuAabb boxes[]; };

ParticleStateRef particle_state() {
    return ParticleStateRef(scene.lighting.lighting.particles);
}

GpuEmitter particle_emitter(ParticleStateRef st, uint slot) {
    return EmittersRef(st.state.emitters).emitters[slot];
}

// One step of `dt` seconds: the velocity takes the acceleration and loses its drag, then the
// position moves by the new velocity (semi-implicit Euler).
void particle_step(inout vec3 position, inout vec3 velocity, vec3 acceleration, float drag, float dt) {
    velocity = (velocity + acceleration * dt) * exp(-drag * dt);
    position += velocity * dt;
}

// How far through its life a particle is, 0 to 1.
float particle_life(GpuParticle p) {
    return clamp(p.age / max(p.lifetime, 1e-6), 0.0, 1.0);
}

#endif
