#version 460
// Ambient occlusion's denoiser (render/src/occlusion): each pixel averages the raw
// occlusion of its 4×4 neighbourhood (the tile of interleaved sample sets, occlusion.glsl),
// weighting each neighbour by how near it lies to the pixel's tangent plane (relative to the
// pixel's distance from the camera), so the average stays on one surface and contact shadows
// keep their edges.
#include "scene.glsl"
#include "depth_normals.glsl"

layout(set = 0, binding = BINDING_OCCLUSION_RAW, r32f) uniform readonly image2D occlusion_raw_in;
layout(set = 0, binding = BINDING_OCCLUSION, r32f) uniform writeonly image2D occlusion_out;

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (!pixel_inside(px)) return;
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) {
        imageStore(occlusion_out, px, vec4(1.0));
        return;
    }
    vec3 p = world_from_depth(vec2(px), depth);
    vec3 n = normal_from_depth_improved(px, depth, p);
    float tolerance = 0.02 * length(scene.camera.camera.position - p);
    float sum = 0.0, weights = 0.0;
    for (int y = -2; y < 2; ++y) {
        for (int x = -2; x < 2; ++x) {
            ivec2 q = px + ivec2(x, y);
            if (!pixel_inside(q)) continue;
            float d = texelFetch(depth_target, q, 0).r;
            if (d <= 0.0) continue;
            float off_plane = dot(n, world_from_depth(vec2(q), d) - p) / tolerance;
            float w = exp(-off_plane * off_plane);
            sum += imageLoad(occlusion_raw_in, q).r * w;
            weights += w;
        }
    }
    imageStore(occlusion_out, px, vec4(weights > 0.0 ? sum / weights : imageLoad(occlusion_raw_in, px).r));
}
