// variants: SCREEN_SPACE
#version 460
// Ambient occlusion from depth (occlusion.glsl): short rays as ray queries on the ray-query
// tier, or (SCREEN_SPACE, every device) ground-truth ambient occlusion over the depth buffer.
#ifndef SCREEN_SPACE
#extension GL_EXT_ray_query : require
#include "shadow_ray_query.glsl"
#endif
#include "occlusion.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    occlusion_pixel(ivec2(gl_GlobalInvocationID.xy));
}
