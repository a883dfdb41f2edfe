#version 460
// Motion vectors, second pass (render/src/motion): the movers, instances that moved or were
// posed since the previous frame, drawn with depth EQUAL over the camera's motion. The clip
// position comes from the expression the depth passes use (mesh_position.glsl), so the test
// passes exactly where the mover is the visible surface.
#define VERTEX_STAGE
#include "scene.glsl"
#include "motion.glsl"
#include "mesh_position.glsl"

layout(location = 0) in vec3 a_position;
layout(location = 0) out vec4 v_now;
layout(location = 1) out vec4 v_before;

invariant gl_Position;

void main() {
    GpuMover mover = MoversRef(scene.lighting.lighting.movers).movers[gl_InstanceIndex];
    GpuInstance inst = scene.instances.instances[mover.slot];
    vec4 world;
    gl_Position = mesh_clip_position(inst.model, a_position, world);
    vec3 before = a_position;
    if (mover.previous != 0ul) {
        before = PreviousPositionsRef(mover.previous).positions[uint(gl_VertexIndex) - mover.vertex_offset].xyz;
    }
    v_now = scene.camera.camera.motion_view_proj * world;
    v_before = scene.camera.camera.prev_view_proj * (mover.prev_model * vec4(before, 1.0));
}
