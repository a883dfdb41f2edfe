// variants: FIRST DOWN UP
#version 460
// Physically based bloom (render/src/bloom; Jimenez, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare", SIGGRAPH 2014): a chain of downsamples, then of upsamples, in compute.
//
// - FIRST: level 0 from the HDR target (half resolution) by the 13-tap filter, its five boxes
//   weighted by 1 / (1 + luma) (Karis's average), so that a lone bright pixel (a firefly, or a
//   highlight that flickers under jitter) cannot bloom into a flashing blob.
// - DOWN: level `scene.texture_index` from the level above by the same 13 taps.
// - UP: level `scene.texture_index` += the level below it, upsampled by a 3×3 tent.
// - (no variant) composite: the HDR target becomes mix(image, bloom, intensity), where bloom is
//   level 0 after the upsamples divided by the level count: every filter's weights sum to one,
//   so the blurred copy carries the image's energy and the blend keeps it.
#include "color.glsl"
#include "bloom.glsl"
#include "storable.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
#if !defined(FIRST) && !defined(DOWN) && !defined(UP)
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;
#endif

#ifdef FIRST
vec3 source(vec2 uv) {
    return texture(hdr_target, uv).rgb;
}
#else
vec3 source(vec2 uv) {
    return bloom_sample(scene.texture_index - 1u, uv);
}
#endif

#if defined(FIRST) || defined(DOWN)
float box_weight(vec3 c) {
#ifdef FIRST
    return 1.0 / (1.0 + luminance(c));
#else
    return 1.0;
#endif
}

// The 13-tap downsample at `uv` of a source whose texel is `t` (uv units): a centre box of four
// taps (weight 1/2) and four corner boxes sharing taps (1/8 each).
vec3 downsample(vec2 uv, vec2 t) {
    vec3 a = source(uv + t * vec2(-2.0, -2.0)), b = source(uv + t * vec2(0.0, -2.0)), c = source(uv + t * vec2(2.0, -2.0));
    vec3 d = source(uv + t * vec2(-1.0, -1.0)), e = source(uv + t * vec2(1.0, -1.0));
    vec3 f = source(uv + t * vec2(-2.0, 0.0)), g = source(uv), h = source(uv + t * vec2(2.0, 0.0));
    vec3 i = source(uv + t * vec2(-1.0, 1.0)), j = source(uv + t * vec2(1.0, 1.0));
    vec3 k = source(uv + t * vec2(-2.0, 2.0)), l = source(uv + t * vec2(0.0, 2.0)), m = source(uv + t * vec2(2.0, 2.0));
    vec3 boxes[5] = vec3[5]((d + e + i + j) * 0.25, (a + b + f + g) * 0.25, (b + c + g + h) * 0.25, (f + g + k + l) * 0.25, (g + h + l + m) * 0.25);
    const float share[5] = float[5](0.5, 0.125, 0.125, 0.125, 0.125);
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (int n = 0; n < 5; ++n) {
        float w = share[n] * box_weight(boxes[n]);
        sum += boxes[n] * w;
        total += w;
    }
    return sum / total;
}
#endif

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
#if defined(FIRST) || defined(DOWN)
#ifdef FIRST
    uint level = 0u;
    vec2 texel = scene.camera.camera.inv_viewport_size;
#else
    uint level = scene.texture_index;
    vec2 texel = 1.0 / vec2(bloom_size(level - 1u));
#endif
    uvec2 size = bloom_size(level);
    if (any(greaterThanEqual(p, size))) return;
    bloom_store(level, p, downsample((vec2(p) + 0.5) / vec2(size), texel));
#elif defined(UP)
    uint level = scene.texture_index;
    uvec2 size = bloom_size(level);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec2 t = 1.0 / vec2(bloom_size(level + 1u));
    vec3 up = vec3(0.0);
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            up += bloom_sample(level + 1u, uv + t * vec2(x, y)) * (float((2 - abs(x)) * (2 - abs(y))) / 16.0);
        }
    }
    bloom_store(level, p, bloom_load(level, ivec2(p)) + up);
#else
    ivec2 px = ivec2(p);
    if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) return;
    vec3 bloom = bloom_sample(0u, (vec2(p) + 0.5) * scene.camera.camera.inv_viewport_size) / float(scene.lighting.lighting.bloom_levels);
    vec4 hdr = imageLoad(hdr_image, px);
    imageStore(hdr_image, px, vec4(storable_radiance(mix(hdr.rgb, bloom, scene.lighting.lighting.bloom_intensity)), hdr.a));
#endif
}
