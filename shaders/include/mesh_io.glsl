// The interface between mesh.vert and every fragment stage that shades meshes.
#ifndef MESH_IO_GLSL
#define MESH_IO_GLSL
#ifdef VERTEX_STAGE
#define IO out
#else
#define IO in
#endif
layout(location = 0) IO vec3 v_world_pos;
layout(location = 1) IO vec3 v_normal;
layout(location = 2) IO vec4 v_tangent;
layout(location = 3) IO vec2 v_uv;
layout(location = 4) flat IO uint v_material;
layout(location = 5) flat IO uint v_instance;
// A posed mesh's rest pose (render/src/skinning): where decals on its skin are looked up.
layout(location = 6) IO vec3 v_rest_pos;
layout(location = 7) IO vec3 v_rest_normal;
layout(location = 8) flat IO uint v_skinned_flag;
#define v_skinned (v_skinned_flag != 0u)
// The first triangle of the level of detail drawn, counted from the mesh's first index
// (render/src/lod): `gl_PrimitiveID + v_triangle_base` numbers a triangle of any level.
layout(location = 9) flat IO uint v_triangle_base;
#undef IO
#ifdef VERTEX_STAGE
// A culled draw's instance slot and level of detail: the level rides above the slot in the
// draw's firstInstance (render/src/lod).
uint drawn_slot() {
    return uint(gl_InstanceIndex) & LOD_SLOT_MASK;
}
uint drawn_level() {
    return uint(gl_InstanceIndex) >> LOD_LEVEL_SHIFT;
}
#endif
#endif
