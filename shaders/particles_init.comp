#version 460
// A new particle pool (render/src/particles): every slot on the free list, the last slot
// deepest, so that the first pops take the lowest slots. The slots were zeroed (free) by the
// pass before.
#include "particles.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

void main() {
    ParticleStateRef st = particle_state();
    uint capacity = st.state.capacity;
    uint i = gl_GlobalInvocationID.x;
    if (i >= capacity) return;
    ParticleSlotsRef(st.state.free_list).slots[i] = capacity - 1u - i;
    if (i == 0u) st.state.free_count = capacity;
}
