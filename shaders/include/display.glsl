// The displayed colour of the HDR target: exposure (the camera's or auto-exposure's) and the
// tone mapper, as the display pass applies them. The post-process anti-aliasing passes (FXAA,
// SMAA) work on what the screen shows.
#ifndef DISPLAY_GLSL
#define DISPLAY_GLSL

#include "scene.glsl"
#include "color.glsl"
#include "exposure.glsl"

vec3 display_color(vec3 hdr) {
    return tonemap(hdr * display_exposure(), scene.lighting.lighting.tonemapper);
}

// Bilinearly filtered at `uv`.
vec3 display_at(vec2 uv) {
    return display_color(texture(hdr_target, uv).rgb);
}

// Pixel `px`, clamped to the image.
vec3 display_texel(ivec2 px) {
    return display_color(texelFetch(hdr_target, clamp(px, ivec2(0), textureSize(hdr_target, 0) - 1), 0).rgb);
}

#endif
