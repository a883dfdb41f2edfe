// variants: GLASS_LAYER
#version 460
// The shadow pass from shadow maps (devices without ray tracing, or asked for): the same
// per-pixel work and output as shadows.comp, each shadow ray replaced by a lookup in the
// light's shadow map (shadow_maps.glsl).
#define SHADOW_MAPS
#include "shadow_pass.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    shadow_pixel(ivec2(gl_GlobalInvocationID.xy));
}
