// variants: GLASS_LAYER SHADOW_MATERIAL
#version 460
// The shadow pass on the ray-query tier (seed 001 §4.3, as the seed wrote it: a compute shader
// with ray queries). Masked materials' candidate hits run the alpha test before they count.
#extension GL_EXT_ray_query : require
#include "shadow_pass.glsl"
#include "shadow_ray_query.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    shadow_pixel(ivec2(gl_GlobalInvocationID.xy));
}
