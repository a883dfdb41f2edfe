// variants: HISTORY_B
#version 460
// Temporal anti-aliasing's resolve (render/src/taa): this frame's jittered colour blended with
// the history reprojected by the motion vectors.
// - Motion is taken from the nearest surface of the 3×3 neighbourhood, so edges of a mover carry
//   its motion rather than the background's.
// - The history is filtered by Catmull-Rom and clipped, in compressed YCoCg, to the box of the
//   current neighbourhood's mean ± 1.25 standard deviations (within its minimum and maximum):
//   what the history shows that the neighbourhood cannot be (a despawned decal, a disoccluded
//   background) is pulled in at once. The blend takes 10 % of this frame, more in motion.
// - Disocclusion: where the history around the reprojected point held a surface over 5 % nearer
//   than the nearest surface here was in the previous frame, or the reprojection leaves the
//   screen, the history is dropped.
// - Interlaced glass (TAA_INTERLACED): odd rows hold glass in depth, so motion and depth come
//   from the even row above, the surface behind; glass does not drag what is behind it.
// Variant HISTORY_B reads history B and writes A; the plain one reads A and writes B.
#include "scene.glsl"
#include "motion.glsl"
#include "taa.glsl"

#ifdef HISTORY_B
layout(set = 0, binding = BINDING_TAA_HISTORY_B) uniform sampler2D history_in;
layout(set = 0, binding = BINDING_TAA_HISTORY_A_STORAGE, rgba16f) uniform writeonly image2D history_out;
#else
layout(set = 0, binding = BINDING_TAA_HISTORY_A) uniform sampler2D history_in;
layout(set = 0, binding = BINDING_TAA_HISTORY_B_STORAGE, rgba16f) uniform writeonly image2D history_out;
#endif
layout(set = 0, binding = BINDING_MOTION, rgba16f) uniform readonly image2D motion_in;
layout(local_size_x = 8, local_size_y = 8) in;

// The share of this frame in the blend where the history is kept and still; it grows with the
// motion (by 0.4 a pixel, up to a third), since every reprojection resamples the history and
// softens it a little: panning over a fine checkerboard kept 71 % of the still image's contrast
// so (49 % with a bilinear history; 51 % at a constant 0.1: tests/tests/antialiasing.rs).
const float CURRENT_WEIGHT = 0.1;

vec3 fetch_current(ivec2 px) {
    vec3 c = texelFetch(hdr_target, px, 0).rgb;
    // A non-finite sample would poison the history for good.
    return all(lessThan(abs(c), vec3(65504.0))) ? max(c, vec3(0.0)) : vec3(0.0);
}

void main() {
    ivec2 size = textureSize(hdr_target, 0);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, size))) return;
    uint flags = scene.texture_index;
    bool interlaced = (flags & TAA_INTERLACED) != 0u;

    vec3 m1 = vec3(0.0), m2 = vec3(0.0), lo = vec3(1e9), hi = vec3(-1e9);
    vec4 nearest = vec4(0.0, 0.0, MOTION_FAR, MOTION_FAR * 2.0);
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 q = clamp(px + ivec2(dx, dy), ivec2(0), size - 1);
            vec3 c = rgb_to_ycocg(taa_compress(fetch_current(q)));
            m1 += c;
            m2 += c * c;
            lo = min(lo, c);
            hi = max(hi, c);
            ivec2 mq = interlaced ? ivec2(q.x, q.y & ~1) : q;
            vec4 m = imageLoad(motion_in, mq);
            if (m.w < nearest.w) nearest = m;
        }
    }
    vec3 current = fetch_current(px);
    ivec2 own = interlaced ? ivec2(px.x, px.y & ~1) : px;
    float depth = imageLoad(motion_in, own).w;

    vec2 prev_uv = (vec2(px) + 0.5) / vec2(size) - nearest.xy;
    bool keep = (flags & TAA_RESET) == 0u && all(greaterThanEqual(prev_uv, vec2(0.0))) && all(lessThanEqual(prev_uv, vec2(1.0)));
    vec3 result = current;
    if (keep) {
        // Disocclusion: the history around the reprojected point held something nearer than
        // the nearest surface here was then (it has moved away). Both sides take the nearest of
        // 3×3 pixels, so jitter moving a thin edge in and out of a pixel does not count.
        ivec2 at = ivec2(prev_uv * vec2(size));
        float history_depth = MOTION_FAR;
        for (int dy = -1; dy <= 1; dy++) {
            for (int dx = -1; dx <= 1; dx++) {
                history_depth = min(history_depth, texelFetch(history_in, clamp(at + ivec2(dx, dy), ivec2(0), size - 1), 0).a);
            }
        }
        keep = history_depth >= nearest.z * 0.95;
    }
    if (keep) {
        vec3 mean = m1 / 9.0;
        vec3 sigma = sqrt(max(m2 / 9.0 - mean * mean, vec3(0.0)));
        vec3 box_lo = max(lo, mean - 1.25 * sigma);
        vec3 box_hi = min(hi, mean + 1.25 * sigma);
        vec3 history = rgb_to_ycocg(taa_compress(sample_catmull_rom(history_in, prev_uv, vec2(size))));
        history = clip_to_box(history, clamp(mean, box_lo, box_hi), box_lo, box_hi);
        float moved = length(nearest.xy * vec2(size)); // pixels
        result = mix(taa_expand(max(ycocg_to_rgb(history), vec3(0.0))), current, min(CURRENT_WEIGHT + 0.4 * moved, 0.33));
    }
    imageStore(history_out, px, vec4(result, depth));
}
