#version 460
// Motion vectors of the movers (motion.vert): clip positions interpolated, divided per pixel.
#include "scene.glsl"
#include "motion.glsl"

layout(location = 0) in vec4 v_now;
layout(location = 1) in vec4 v_before;
layout(location = 0) out vec4 out_motion;

void main() {
    out_motion = motion_record(v_now, v_before, abs(v_now.w), abs(v_before.w));
}
