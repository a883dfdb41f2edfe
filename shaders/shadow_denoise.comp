#version 460
// The sampled shadows' denoiser (render/src/lights/sampling): the ratio estimator of Heitz et
// al. 2018 over a 3×3 neighbourhood (5×5 blurred the shadows' edges: 1.8 times the error against
// a ray per light, in tests/tests/suite/lights.rs's `sampled_shadows_averaged_over_blocks_…`). Each pixel that sampled its lights averages its
// neighbours' shadow-ray visibility V, each weighted by the neighbour's estimate S of its
// unshadowed light (so the ratio is ΣSV / ΣS, the share of the light that got through) and by
// how near it lies to the pixel's tangent plane (as ambient occlusion's denoiser weighs, so the
// average stays on one surface and contact shadows keep their edges). Temporal anti-aliasing,
// where it runs, averages the result over frames as the draws change.
#include "scene.glsl"
#include "depth_normals.glsl"
#include "direct_sampling.glsl"

layout(set = 0, binding = BINDING_SHADOW_SAMPLES, rgba16f) uniform readonly image2D shadow_samples_in;
layout(set = 0, binding = BINDING_SHADOW_RATIO, rgba16f) uniform writeonly image2D shadow_ratio_out;

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (!pixel_inside(px)) return;
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) {
        // Nothing to shade here; but a multisampled edge may shade a sample of this pixel.
        imageStore(shadow_ratio_out, px, vec4(1.0));
        return;
    }
    // Only pixels that sampled are read by shading (with `auto`, tiles of few lights did not).
    if (!samples_lights(light_list(px))) return;
    vec4 own = imageLoad(shadow_samples_in, px);
    vec3 p = world_from_depth(vec2(px), depth);
    vec3 n = normal_from_depth_improved(px, depth, p);
    float tolerance = 0.02 * length(scene.camera.camera.position - p);
    // Weights relative to the pixel's own estimate, which keeps them within half floats' range.
    float reference = own.a > SAMPLED_NONE ? own.a : 0.0;
    vec3 sum = vec3(0.0);
    float weights = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            ivec2 q = px + ivec2(x, y);
            if (!pixel_inside(q)) continue;
            float d = texelFetch(depth_target, q, 0).r;
            if (d <= 0.0) continue;
            vec4 sampled = imageLoad(shadow_samples_in, q);
            if (!(sampled.a > SAMPLED_NONE)) continue;
            float off_plane = dot(n, world_from_depth(vec2(q), d) - p) / tolerance;
            // A neighbour counts by its light, up to 64 times the pixel's own either way: a
            // neighbour off the pixel's plane with far more light would otherwise outweigh the
            // plane's test and carry its shadow across a silhouette.
            float w = exp(-off_plane * off_plane) * exp2(clamp(sampled.a - reference, -6.0, 6.0));
            sum += sampled.rgb * w;
            weights += w;
        }
    }
    imageStore(shadow_ratio_out, px, vec4(weights > 0.0 ? sum / weights : vec3(1.0), 1.0));
}
