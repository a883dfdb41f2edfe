#version 460
// Exposure and tone mapping of the HDR colour target into the display target.
#include "scene.glsl"
#include "color.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 hdr = texture(hdr_target, v_uv).rgb;
    out_color = vec4(pbr_neutral(hdr * scene.camera.camera.exposure), 1.0);
}
