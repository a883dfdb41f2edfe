#version 460
// Depth peeling (seed 002 §4.1.2): keeps the opaque layer's depth for the composition's
// refraction check (transparency_peeled.comp) before the nearest layer's G-buffer replaces it.
// A compute copy into R32F: on the lent H100 a transfer copy of the D32 target took 0.44 ms at
// 1920×1080.
#include "scene.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = BINDING_BACKGROUND_DEPTH_STORAGE, r32f) uniform writeonly image2D background_depth_out;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) return;
    imageStore(background_depth_out, px, vec4(texelFetch(depth_target, px, 0).r));
}
