// The displayed colour of the HDR target: exposure (the camera's or auto-exposure's) and the
// tone mapper, as the display pass applies them. The post-process anti-aliasing passes (FXAA,
// SMAA) work on what the screen shows.
#ifndef DISPLAY_GLSL
#define DISPLAY_GLSL

#include "scene.glsl"
#include "color.glsl"
#include "exposure.glsl"
#include "storable.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) buffer DisplayCheckRef { uint non_finite; };

// The debug builds' check of the tone mapper's input (render/src/present/check.rs): counts an HDR
// value that is not finite (no pass should have written one). Release builds leave the address
// 0, and ordinary pixels never take the branch.
void check_display_input(vec3 hdr) {
    uint64_t address = scene.lighting.lighting.display_check;
    if (address != 0ul && (any(isnan(hdr)) || any(isinf(hdr)))) atomicAdd(DisplayCheckRef(address).non_finite, 1u);
}

// Exposed and tone mapped; whatever reaches it is displayed as storable radiance, so the picture
// is finite even where the check counts.
vec3 display_color(vec3 hdr) {
    return tonemap(storable_radiance(hdr * display_exposure()), scene.lighting.lighting.tonemapper);
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
