// variants: ANTIALIASED
#version 460
// Exposure and tone mapping of the HDR colour target into the display target; the ANTIALIASED
// variant copies out the colour the FXAA or SMAA passes (fxaa.comp, smaa_blend.comp) already
// tone mapped and anti-aliased. Both check the HDR pixel in debug builds (check_display_input).
#include "display.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 0) out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    check_display_input(texelFetch(hdr_target, clamp(px, ivec2(0), textureSize(hdr_target, 0) - 1), 0).rgb);
#ifdef ANTIALIASED
    out_color = vec4(texelFetch(antialiased, px, 0).rgb, 1.0);
#else
    out_color = vec4(display_at(v_uv), 1.0);
#endif
}
