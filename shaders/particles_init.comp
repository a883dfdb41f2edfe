#version 460
// A new particle pool (render/src/particles): every slot on the free list, the last slot
// deepest, so that the first pops take the lowest slots; every place of the decal ring a box
// of no decal. The slots and the decal records were zeroed (free; no receiver) by the pass
// before.
#include "particles.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

void main() {
    ParticleStateRef st = particle_state();
    uint capacity = st.state.capacity;
    uint i = gl_GlobalInvocationID.x;
    if (i < st.state.decal_room) ParticleDecalBoxesRef(st.state.decal_boxes).boxes[i].slot = NO_DECAL;
    if (i >= capacity) return;
    ParticleSlotsRef(st.state.free_list).slots[i] = capacity - 1u - i;
    if (i == 0u) st.state.free_count = capacity;
}
