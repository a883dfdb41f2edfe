#version 460
// The reflection pass's resolve (render/src/reflections): each pixel that reflects gathers the
// radiance its neighbourhood's rays brought back, weighted by a Gaussian whose width grows with
// its roughness (none for a mirror at full resolution) and by how close each tracing pixel's
// distance from the camera is to its own (so nothing bleeds across depth edges; at half
// resolution this is the depth-aware upsample), and adds it to the HDR target in place of the
// ambient term's specular part: `hdr += weight × (reflected − ambient)`.
#include "scene.glsl"
#include "depth.glsl"
#include "heatmap.glsl"

layout(set = 0, binding = BINDING_REFLECTION, rgba16f) uniform readonly image2D reflection_in;
layout(set = 0, binding = BINDING_REFLECTION_WEIGHT, rgba16f) uniform readonly image2D weight_in;
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;
layout(local_size_x = 8, local_size_y = 8) in;

// Roughness below which a surface is a mirror (as in reflections.glsl).
const float MIRROR = 0.05;

// The distance from the camera to what pixel `p` sees (negative for the sky).
float distance_at(ivec2 p) {
    float depth = depth_at(p);
    return depth > 0.0 ? length(scene.camera.camera.position - world_from_depth(vec2(p), depth)) : -1.0;
}

// The change of that distance one step along `dir`, from the neighbour on the same side as the
// surface (the nearer in distance; neither past an edge of the image or on the sky).
float distance_slope(ivec2 px, float d, ivec2 dir) {
    ivec2 size = ivec2(scene.camera.camera.viewport_size);
    float plus = all(lessThan(px + dir, size)) ? distance_at(px + dir) : -1.0;
    float minus = all(greaterThanEqual(px - dir, ivec2(0))) ? distance_at(px - dir) : -1.0;
    bool use_plus = plus > 0.0 && (minus <= 0.0 || abs(plus - d) <= abs(minus - d));
    if (use_plus) return plus - d;
    return minus > 0.0 ? d - minus : 0.0;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    GpuCamera cam = scene.camera.camera;
    if (any(greaterThanEqual(px, ivec2(cam.viewport_size)))) return;
    vec4 weight = imageLoad(weight_in, px);
    GpuLighting l = scene.lighting.lighting;
    bool half_res = (l.reflection_flags & REFLECT_HALF_RES) != 0u;
    ivec2 grid = half_res ? (ivec2(cam.viewport_size) + 1) / 2 : ivec2(cam.viewport_size);
    ivec2 at = half_res ? px / 2 : px;
    vec4 hdr = imageLoad(hdr_image, px);
    if (scene.debug_view == DEBUG_REFLECTIONS) {
        vec4 ray = imageLoad(reflection_in, at);
        hdr.rgb = weight.a < 0.0 ? hdr.rgb * 0.2 : (ray.a > 0.0 ? ray.rgb : vec3(0.0));
        imageStore(hdr_image, px, hdr);
        return;
    }
    if (weight.a < 0.0 || all(equal(weight.rgb, vec3(0.0)))) return;

    float distance = distance_at(px);
    // How the distance changes per pixel across this surface, so that rays traced from the same
    // surface are recognised however slanted it is (a floor seen at a grazing angle changes by
    // several per cent a row).
    vec2 slope = vec2(distance_slope(px, distance, ivec2(1, 0)), distance_slope(px, distance, ivec2(0, row_step())) / float(row_step()));
    // The tracing pixel of a half-resolution ray is somewhere in its 2×2 block.
    float slack = 0.02 * distance + (half_res ? abs(slope.x) + abs(slope.y) : 0.0);
    vec3 reflected;
    vec4 own = imageLoad(reflection_in, at);
    if (!half_res && weight.a < MIRROR && own.a > 0.0) {
        reflected = own.rgb;
    } else if (weight.a < MIRROR) {
        // A mirror at half resolution: bilinear between the four nearest rays (each traced from
        // its block's top-left pixel when that one reflects), by depth.
        vec2 g = vec2(px) * 0.5;
        ivec2 q0 = ivec2(floor(g));
        vec2 f = g - vec2(q0);
        vec3 sum = vec3(0.0);
        float total = 0.0;
        for (int i = 0; i < 4; ++i) {
            ivec2 o = ivec2(i & 1, i >> 1);
            ivec2 q = min(q0 + o, grid - 1);
            vec4 ray = imageLoad(reflection_in, q);
            if (ray.a <= 0.0) continue;
            vec2 offset = vec2(q * 2 - px);
            float depth_weight = clamp(1.0 - abs(ray.a - (distance + dot(slope, offset))) / slack, 0.0, 1.0);
            vec2 b = mix(1.0 - f, f, vec2(o));
            float w = b.x * b.y * depth_weight + 1e-4 * depth_weight;
            sum += ray.rgb * w;
            total += w;
        }
        if (total <= 0.0) return;
        reflected = sum / total;
    } else {
        // Glossy: a Gaussian over 5×5 taps `stride` apart, sigma in rays from 0.6 (one at half
        // resolution) to about four for the roughest surface that reflects.
        float sigma = max(half_res ? 1.0 : 0.6, 4.0 * weight.a / max(l.reflection_cutoff, 1e-3));
        int stride = max(1, int(round(sigma * 0.5)));
        vec3 sum = vec3(0.0);
        float total = 0.0;
        for (int dy = -2; dy <= 2; ++dy) {
            for (int dx = -2; dx <= 2; ++dx) {
                ivec2 q = at + ivec2(dx, dy) * stride;
                if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, grid))) continue;
                vec4 ray = imageLoad(reflection_in, q);
                if (ray.a <= 0.0) continue;   // no ray there
                float d2 = float(dx * dx + dy * dy) * float(stride * stride);
                // The tracing pixel's offset from this one (a half-resolution ray's block corner).
                vec2 offset = vec2(half_res ? q * 2 - px : q - px);
                float depth_weight = clamp(1.0 - abs(ray.a - (distance + dot(slope, offset))) / slack, 0.0, 1.0);
                float w = exp(-0.5 * d2 / (sigma * sigma)) * depth_weight;
                sum += ray.rgb * w;
                total += w;
            }
        }
        if (total < 1e-4) return;   // no ray on this surface nearby: the ambient term stays
        reflected = sum / total;
    }
    hdr.rgb = max(hdr.rgb + weight.rgb * (reflected - cam.ambient), vec3(0.0));
    imageStore(hdr_image, px, hdr);
}
