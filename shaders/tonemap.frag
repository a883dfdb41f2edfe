// variants: FXAA
#version 460
// Exposure and tone mapping of the HDR colour target into the display target; the FXAA variant
// anti-aliases the displayed image in the same pass (include/fxaa.glsl), tone mapping each of
// its taps, so no intermediate image is written.
#include "scene.glsl"
#include "color.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 0) out vec4 out_color;

vec3 fxaa_display(vec2 uv) {
    return pbr_neutral(texture(hdr_target, uv).rgb * scene.camera.camera.exposure);
}

#ifdef FXAA
#include "fxaa.glsl"
#endif

void main() {
#ifdef FXAA
    out_color = vec4(fxaa(v_uv, 1.0 / vec2(textureSize(hdr_target, 0))), 1.0);
#else
    out_color = vec4(fxaa_display(v_uv), 1.0);
#endif
}
