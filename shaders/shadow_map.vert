#version 460
// The shadow-map pass's vertex stage: the scene's meshes into the view `scene.texture_index`
// of the shadow-map atlas (shadow_maps.glsl).
#define VERTEX_STAGE
#include "scene.glsl"
#include "mesh_io.glsl"
#include "shadow_maps.glsl"

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_tangent;

void main() {
    uint slot = drawn_slot();
    GpuInstance inst = scene.instances.instances[slot];
    vec4 world = inst.model * vec4(a_position, 1.0);
    v_world_pos = world.xyz;
    v_normal = mat3(inst.normal_model) * a_normal;
    v_tangent = vec4(mat3(inst.model) * a_tangent.xyz, a_tangent.w);
    v_uv = a_uv;
    v_material = inst.material;
    v_instance = slot;
    v_triangle_base = 0u; // depth only: no triangle numbers are stored
    gl_Position = shadow_view(scene.texture_index).view_proj * world;
}
