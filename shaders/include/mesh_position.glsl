// Where a mesh vertex lands: one expression for every pass that must reproduce another pass's
// depth exactly (the shading pass tests EQUAL against the prepass; the motion-vector pass against
// whichever pass wrote depth).
#ifndef MESH_POSITION_GLSL
#define MESH_POSITION_GLSL

// The clip position of object-space `position` of an instance placed by `model`, and its world
// position.
vec4 mesh_clip_position(mat4 model, vec3 position, out vec4 world) {
    world = model * vec4(position, 1.0);
    return scene.camera.camera.view_proj * world;
}

#endif
