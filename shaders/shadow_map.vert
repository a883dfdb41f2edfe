#version 460
// The shadow-map pass's vertex stage: the scene's meshes into the view `scene.texture_index`
// of the shadow-map atlas (shadow_maps.glsl).
#define VERTEX_STAGE
#include "scene.glsl"
#include "mesh_io.glsl"
#include "shadow_maps.glsl"

// The packed vertex (vertex.glsl), as mesh.vert reads it.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in uint a_tangent;

void main() {
    uint slot = drawn_slot();
    GpuInstance inst = scene.instances.instances[slot];
    vec4 world = inst.model * vec4(a_position, 1.0);
    v_world_pos = world.xyz;
    vec4 tangent = unpack_tangent(a_tangent);
    v_normal = mat3(inst.normal_model) * oct_decode(a_normal);
    v_tangent = vec4(mat3(inst.model) * tangent.xyz, tangent.w);
    MeshesRef meshes = MeshesRef(scene.meshes);
    v_uv = meshes.meshes[inst.mesh].uv_offset + a_uv * meshes.meshes[inst.mesh].uv_scale;
    v_material = inst.material;
    v_instance = slot;
    v_triangle_base = 0u; // depth only: no triangle numbers are stored
    gl_Position = shadow_view(scene.texture_index).view_proj * world;
}
