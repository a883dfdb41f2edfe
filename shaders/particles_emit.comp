#version 460
// Particle emission (render/src/particles): one invocation per particle started this frame.
// Each finds its job (the emitter and the job's seed), pops a slot off the free list and starts
// the particle: born in the emitter's sphere, launched in its cone about +Y at a speed between
// its bounds, to live between its bounds. A pop that finds the list empty is a dropped particle.
#include "particles.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

void main() {
    ParticleStateRef st = particle_state();
    uint i = gl_GlobalInvocationID.x;
    if (i >= st.state.spawn_count) return;
    // The last job starting at or before i (jobs are in order of `first`).
    uint lo = 0u, hi = st.state.job_count;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (st.jobs[mid].first <= i) lo = mid; else hi = mid;
    }
    GpuEmission job = st.jobs[lo];
    // The free list is a stack: a pop past its bottom is undone and counted.
    uint before = atomicAdd(st.state.free_count, 0xFFFFFFFFu);
    if (int(before) <= 0) {
        atomicAdd(st.state.free_count, 1u);
        atomicAdd(st.state.dropped, 1u);
        return;
    }
    uint slot = ParticleSlotsRef(st.state.free_list).slots[before - 1u];
    GpuEmitter e = particle_emitter(st, job.emitter);
    uint seed = pcg_hash(job.seed ^ pcg_hash(i - job.first));

    // Direction: uniform over the cap of the cone (cos θ uniform in [cone_cos, 1]).
    float cos_t = mix(1.0, e.cone_cos, random01(seed));
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float phi = 6.28318531 * random01(seed);
    vec3 local = vec3(sin_t * cos(phi), cos_t, sin_t * sin(phi));
    mat3 basis = mat3(e.transform);
    vec3 axis = basis * local;
    vec3 dir = dot(axis, axis) > 1e-12 ? normalize(axis) : vec3(0.0, 1.0, 0.0);
    // Birthplace: uniform in the sphere of `spawn_radius`.
    float u = random01(seed);
    float w = 2.0 * random01(seed) - 1.0;
    float a = 6.28318531 * random01(seed);
    float r = e.spawn_radius * pow(u, 1.0 / 3.0);
    vec3 offset = r * vec3(sqrt(1.0 - w * w) * cos(a), w, sqrt(1.0 - w * w) * sin(a));

    GpuParticle p;
    p.position = e.transform[3].xyz + offset;
    p.age = 0.0;
    p.velocity = dir * mix(e.speed_min, e.speed_max, random01(seed));
    p.lifetime = max(mix(e.lifetime_min, e.lifetime_max, random01(seed)), 1e-3);
    p.emitter = job.emitter;
    p.seed = seed;
    p.flags = 0u;
    p.contact_normal = 0u;
    ParticlesRef(st.state.pool).particles[slot] = p;
    atomicAdd(st.state.spawned, 1u);
}
