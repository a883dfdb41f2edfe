#version 460
// One vertex shader for the depth prepass and the shading pass, so that both produce bit-identical
// depth (the shading pass tests EQUAL against the prepass).
#define VERTEX_STAGE
#include "scene.glsl"
#include "mesh_io.glsl"
#include "mesh_position.glsl"

// The packed vertex (vertex.glsl): the fetch unpacks the octahedral normal and the UV's unorm16.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in uint a_tangent;

invariant gl_Position;

void main() {
    uint slot = drawn_slot();
    GpuInstance inst = scene.instances.instances[slot];
    vec4 world;
    gl_Position = mesh_clip_position(inst.model, a_position, world);
    v_world_pos = world.xyz;
    vec3 normal = oct_decode(a_normal);
    vec4 tangent = unpack_tangent(a_tangent);
    v_normal = mat3(inst.normal_model) * normal;
    v_tangent = vec4(mat3(inst.model) * tangent.xyz, tangent.w);
    MeshesRef meshes = MeshesRef(scene.meshes);
    v_uv = meshes.meshes[inst.mesh].uv_offset + a_uv * meshes.meshes[inst.mesh].uv_scale;
    v_material = inst.material;
    v_instance = slot;
    uint level = drawn_level();
    v_triangle_base = level == 0u ? 0u : (meshes.meshes[inst.mesh].lod_first[level - 1u] - meshes.meshes[inst.mesh].first_index) / 3u;
    // A posed mesh carries its rest pose along (the same vertex of its source's vertices).
    // (Field by field: only what is used is fetched, not the whole record.)
    uint64_t rest_vertices = meshes.meshes[inst.mesh].rest;
    v_skinned_flag = rest_vertices != meshes.meshes[inst.mesh].vertices ? 1u : 0u;
    v_rest_pos = v_world_pos;
    v_rest_normal = v_normal;
    if (v_skinned_flag != 0u) {
        GpuVertex rest = VerticesRef(rest_vertices).vertices[uint(gl_VertexIndex) - meshes.meshes[inst.mesh].vertex_offset];
        v_rest_pos = (inst.model * vec4(rest.position, 1.0)).xyz;
        v_rest_normal = mat3(inst.normal_model) * unpack_normal(rest.normal);
    }
}
