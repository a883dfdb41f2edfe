#version 460
// FXAA (include/fxaa.glsl) in compute: tone maps the HDR target and anti-aliases it into the
// anti-aliased colour target, which the display pass then copies into the display image
// (render/src/present/tonemap.rs says why this is not fused into that fragment pass).
#include "display.glsl"

layout(set = 0, binding = BINDING_ANTIALIASED_STORAGE, rgba16f) uniform writeonly image2D antialiased_out;
layout(local_size_x = 8, local_size_y = 8) in;

vec3 fxaa_display(vec2 uv) {
    return display_at(uv);
}

#include "fxaa.glsl"

void main() {
    ivec2 size = textureSize(hdr_target, 0);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, size))) return;
    vec2 texel = 1.0 / vec2(size);
    imageStore(antialiased_out, px, vec4(fxaa((vec2(px) + 0.5) * texel, texel), 1.0));
}
