// variants: GLASS_LAYER SEPARATE
#version 460
// The reflection pass's resolve (render/src/reflections): each pixel that reflects gathers the
// radiance its neighbourhood's rays brought back, weighted by a Gaussian whose width grows with
// its roughness (none for a mirror at full resolution; bilinear between the four nearest rays
// for a mirror at half) and by how well each tracing pixel's distance from the camera agrees
// with this surface's, extrapolated along its slope (so nothing bleeds across depth edges; at
// half resolution this is the depth-aware upsample). It adds the result to the HDR target in
// place of the ambient term's specular part: each ray stored what it brought beyond the
// environment's prefiltered radiance (or the ambient colour) its surface was shaded with, so
// `hdr += weight × (reflected − ambient)` is `weight × resolved`. It also
// sums the cells' statistics (pack_cell in reflections.glsl) into the statistics buffer, one
// atomic add per workgroup and counter. SEPARATE (MSAA, render/src/msaa) runs before the shading
// pass and stores the term instead (zero where nothing reflects), which the shading pass adds to
// each sample from the pixel of its own surface.
#include "scene.glsl"
#include "depth.glsl"
#include "storable.glsl"

layout(set = 0, binding = BINDING_REFLECTION, rgba16f) uniform readonly image2D reflection_in;
layout(set = 0, binding = BINDING_REFLECTION_WEIGHT, rgba16f) uniform readonly image2D weight_in;
layout(set = 0, binding = BINDING_REFLECTION_RAYS, r32ui) uniform readonly uimage2D rays_in;
#ifdef SEPARATE
layout(set = 0, binding = BINDING_REFLECTION_ADDED, rgba16f) uniform writeonly image2D added_out;
#else
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;
#endif
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ReflectionStatsRef { uint words[]; };
layout(local_size_x = 8, local_size_y = 8) in;

// Roughness below which a surface is a mirror (as in reflections.glsl).
const float MIRROR = 0.05;
// GpuLighting::reflection_stats: pixels that reflect, rays, hits, decals tested and lights found
// at hit points, rays through glass.
shared uint counts[6];

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

// The pixel that traced cell `q`'s ray (`side` 1 or 2).
ivec2 tracer_of(ivec2 q, int side) {
    uint tracer = imageLoad(rays_in, q).r >> 30;
    return q * side + ivec2(int(tracer) % side, int(tracer) / side);
}

void count_cell(ivec2 px, int side) {
    if (any(notEqual(px % side, ivec2(0)))) return;   // one pixel per cell counts it
    uint word = imageLoad(rays_in, px / side).r;
    atomicAdd(counts[0], (word >> 24) & 7u);
    if ((word & (1u << 27)) == 0u) return;
    atomicAdd(counts[1], 1u);
    if ((word & (1u << 28)) != 0u) atomicAdd(counts[2], 1u);
    atomicAdd(counts[3], word & 0xFFFu);
    atomicAdd(counts[4], (word >> 12) & 0xFFFu);
    if ((word & (1u << 29)) != 0u) atomicAdd(counts[5], 1u);
}

vec3 resolve(ivec2 px, vec4 weight, bool half_res) {
    GpuCamera cam = scene.camera.camera;
    GpuLighting l = scene.lighting.lighting;
    int side = half_res ? 2 : 1;
    ivec2 grid = (ivec2(cam.viewport_size) + side - 1) / side;
    ivec2 at = px / side;
#ifdef GLASS_LAYER
    // Glass is not in the depth buffer: its ray's own distance stands for it, flat.
    float distance = imageLoad(reflection_in, at).a;
    vec2 slope = vec2(0.0);
#else
    float distance = distance_at(px);
    // How the distance changes per pixel across this surface, so that rays traced from the same
    // surface are recognised however slanted it is (a floor seen at a grazing angle changes by
    // several per cent a row).
    vec2 slope = vec2(distance_slope(px, distance, ivec2(1, 0)), distance_slope(px, distance, ivec2(0, row_step())) / float(row_step()));
#endif
    float slack = 0.02 * distance;
    vec4 own = imageLoad(reflection_in, at);
    if (!half_res && weight.a < MIRROR && own.a > 0.0) return own.rgb;
    // A mirror at half resolution: bilinear between the four nearest rays, by depth. Glossy: a
    // Gaussian over 5×5 rays `stride` apart, sigma from 0.6 ray (one at half resolution) to
    // about four for the roughest surface that reflects.
    bool mirror = weight.a < MIRROR;
    float sigma = max(half_res ? 1.0 : 0.6, 4.0 * weight.a / max(l.reflection_cutoff, 1e-3));
    int stride = mirror ? 1 : max(1, int(round(sigma * 0.5)));
    int lo = mirror ? 0 : -2, hi = mirror ? 1 : 2;
    ivec2 base = mirror ? ivec2(floor(vec2(px) * 0.5)) : at;
    vec2 f = vec2(px) * 0.5 - vec2(base);
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (int dy = lo; dy <= hi; ++dy) {
        for (int dx = lo; dx <= hi; ++dx) {
            ivec2 q = base + ivec2(dx, dy) * stride;
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, grid))) continue;
            vec4 ray = imageLoad(reflection_in, q);
            if (ray.a <= 0.0) continue;   // no ray there
            vec2 offset = vec2(tracer_of(q, side) - px);
            float depth_weight = clamp(1.0 - abs(ray.a - (distance + dot(slope, offset))) / slack, 0.0, 1.0);
            float w;
            if (mirror) {
                vec2 b = mix(1.0 - f, f, vec2(dx, dy));
                w = (b.x * b.y + 1e-4) * depth_weight;
            } else {
                w = exp(-0.5 * float(dx * dx + dy * dy) * float(stride * stride) / (sigma * sigma)) * depth_weight;
            }
            sum += ray.rgb * w;
            total += w;
        }
    }
    // No ray on this surface nearby: the ambient term stays.
    return total < 1e-6 ? vec3(0.0) : sum / total;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    uint local = gl_LocalInvocationIndex;
    GpuCamera cam = scene.camera.camera;
    GpuLighting l = scene.lighting.lighting;
    bool half_res = (l.reflection_flags & REFLECT_HALF_RES) != 0u;
    bool inside = all(lessThan(px, ivec2(cam.viewport_size)));
    if (local < 6u) counts[local] = 0u;
    barrier();
    if (inside) count_cell(px, half_res ? 2 : 1);
    barrier();
    if (local < 6u && counts[local] != 0u && l.reflection_stats != 0ul) atomicAdd(ReflectionStatsRef(l.reflection_stats).words[local], counts[local]);
    if (!inside) return;

    vec4 weight = imageLoad(weight_in, px);
#ifdef SEPARATE
    bool reflects = weight.a >= 0.0 && any(notEqual(weight.rgb, vec3(0.0)));
    imageStore(added_out, px, vec4(reflects ? weight.rgb * resolve(px, weight, half_res) : vec3(0.0), 0.0));
#else
    vec4 hdr = imageLoad(hdr_image, px);
    if (scene.debug_view == DEBUG_REFLECTIONS) {
        vec4 ray = imageLoad(reflection_in, half_res ? px / 2 : px);
        hdr.rgb = weight.a < 0.0 ? hdr.rgb * 0.2 : (ray.a > 0.0 ? ray.rgb : vec3(0.0));
        imageStore(hdr_image, px, hdr);
        return;
    }
    if (weight.a < 0.0 || all(equal(weight.rgb, vec3(0.0)))) return;
    hdr.rgb = storable_radiance(max(hdr.rgb + weight.rgb * resolve(px, weight, half_res), vec3(0.0)));
    imageStore(hdr_image, px, hdr);
#endif
}
