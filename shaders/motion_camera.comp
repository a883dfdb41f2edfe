#version 460
// Motion vectors, first pass (render/src/motion): every pixel's motion as if nothing but the
// camera moved, from depth. The point under the pixel (homogeneous, so that the sky, at infinite
// depth, moves as a direction) is projected by this frame's and the previous frame's unjittered
// view-projections. The movers pass then draws what moved by itself over this.
#include "scene.glsl"
#include "motion.glsl"

layout(set = 0, binding = BINDING_MOTION, rgba16f) uniform writeonly image2D motion_out;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 size = textureSize(depth_target, 0);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, size))) return;
    GpuCamera cam = scene.camera.camera;
    float depth = texelFetch(depth_target, px, 0).r;
    // The viewport is flipped (include/depth.glsl): row 0 is NDC y = +1.
    vec2 ndc = ((vec2(px) + 0.5) / vec2(size) * 2.0 - 1.0) * vec2(1.0, -1.0);
    vec4 world = cam.inv_view_proj * vec4(ndc, depth, 1.0);
    vec4 now = cam.motion_view_proj * world;
    vec4 before = cam.prev_view_proj * world;
    // View depths: the clip w of a point, once the homogeneous point is divided out.
    bool sky = depth <= 0.0;
    float depth_now = sky ? MOTION_FAR : abs(now.w / world.w);
    float depth_before = sky ? MOTION_FAR : abs(before.w / world.w);
    imageStore(motion_out, px, motion_record(now, before, depth_now, depth_before));
}
