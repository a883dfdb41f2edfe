#version 460
// The scene TLAS's instance records, written on the GPU from the instance table the renderer
// already keeps (render/src/accel/mod.rs): instance i is slot i, its custom index the slot,
// its BLAS its mesh's (none for a free slot or a mesh without one: such an instance is
// inactive), opaque unless its material is alpha-masked or blended (their hits run the any-hit
// test: the mask, or glass filtering the light, shaders/include/alpha_mask.glsl).
#include "scene.glsl"

layout(local_size_x = 64) in;

struct AsInstance {
    vec4 rows[3];               // object to world, row-major 3×4
    uint custom_index_and_mask; // 24 + 8 bits
    uint sbt_offset_and_flags;  // 24 + 8 bits
    uint64_t blas;
};
layout(buffer_reference, scalar, buffer_reference_align = 8) writeonly buffer AsInstancesRef { AsInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer BlasTableRef { uint64_t blas[]; };

const uint TRIANGLE_FACING_CULL_DISABLE = 1u;
const uint FORCE_OPAQUE = 4u;
const uint FORCE_NO_OPAQUE = 8u;

void main() {
    GpuLighting l = scene.lighting.lighting;
    uint i = gl_GlobalInvocationID.x;
    if (i >= l.instance_count) return;
    GpuInstance inst = scene.instances.instances[i];
    mat4 m = inst.model;
    AsInstance o;
    o.rows[0] = vec4(m[0][0], m[1][0], m[2][0], m[3][0]);
    o.rows[1] = vec4(m[0][1], m[1][1], m[2][1], m[3][1]);
    o.rows[2] = vec4(m[0][2], m[1][2], m[2][2], m[3][2]);
    uint64_t blas = 0ul;
    if (inst.live != 0u && inst.mesh < l.blas_count) blas = BlasTableRef(l.scene_blas_table).blas[inst.mesh];
    // A non-finite transform must not reach the builder, and the instance must not turn inactive
    // either (an update may not change an instance between active and inactive, and a transform
    // alone changes by update): it keeps its BLAS with a zero transform and a zero mask, so no
    // ray finds it.
    bool finite = true;
    for (int r = 0; r < 3; ++r) finite = finite && !any(isnan(o.rows[r])) && !any(isinf(o.rows[r]));
    if (!finite) {
        o.rows[0] = vec4(0.0);
        o.rows[1] = vec4(0.0);
        o.rows[2] = vec4(0.0);
    }
    uint flags = scene.materials.materials[inst.material].flags;
    bool tested = (flags & (MATERIAL_ALPHA_MASK | MATERIAL_BLEND)) != 0u;
    o.custom_index_and_mask = (i & 0xFFFFFFu) | ((finite ? 0xFFu : 0u) << 24);
    o.sbt_offset_and_flags = (TRIANGLE_FACING_CULL_DISABLE | (tested ? FORCE_NO_OPAQUE : FORCE_OPAQUE)) << 24;
    o.blas = blas;
    AsInstancesRef(l.scene_instances).instances[i] = o;
}
