// Ambient occlusion (render/src/occlusion): the share of a pixel's cosine-weighted
// hemisphere that is open to the environment within `occlusion_radius`, which multiplies the
// environment's and the ambient colour's light (the material's occlusion and the specular
// occlusion derived from it, environment.glsl). From depth alone, like the shadow pass, so one
// pass serves every pipeline:
//   - traced (both ray-tracing tiers): `occlusion_rays` short rays per pixel against the scene
//     TLAS, cosine-distributed about the normal rebuilt from depth; glass lets its transmittance
//     through, as it does for shadows. The including shader defines shadow_ray_transmittance
//     (shadow_ray_query.glsl or shadow_ray_pipeline.glsl).
//   - SCREEN_SPACE (every device): ground-truth ambient occlusion (Jimenez, Wu, Pesce and
//     Jarabo, "Practical Real-Time Strategies for Accurate Indirect Occlusion", 2016): per slice
//     of the hemisphere through the view vector, the two horizons found by marching the depth
//     buffer, and the cosine-weighted visible arc between them integrated in closed form.
// Noise: each pixel of a 4×4 tile takes its own sixteenth of a stratified set of directions
// (rays, or GTAO's slice angles), the same every frame, so the image is stable without a
// temporal filter; the denoiser (occlusion_denoise.comp) averages 4×4 neighbourhoods over one
// surface, so each pixel's result draws on 16× its own samples.
#ifndef OCCLUSION_GLSL
#define OCCLUSION_GLSL

#include "color.glsl"
#include "scene.glsl"
#include "depth_normals.glsl"
#include "lighting.glsl"
#include "brdf.glsl"

layout(set = 0, binding = BINDING_OCCLUSION_RAW, r32f) uniform writeonly image2D occlusion_raw_out;

// The pixel's place in the 4×4 interleaving (a Bayer matrix: neighbours far apart in order).
uint occlusion_pattern(ivec2 px) {
    const uint bayer[16] = uint[16](0u, 8u, 2u, 10u, 12u, 4u, 14u, 6u, 3u, 11u, 1u, 9u, 15u, 7u, 13u, 5u);
    return bayer[(px.y & 3) * 4 + (px.x & 3)];
}

#ifdef SCREEN_SPACE
const uint GTAO_SLICES = 2u;
const uint GTAO_STEPS = 6u;   // per side of a slice

// The screen-space horizon's cosine on one side of a slice (`dir` in pixels per step unit).
float gtao_horizon(ivec2 px, vec3 p, vec3 v, vec2 dir, float radius_px, float radius, float low, float jitter) {
    float horizon = low;
    vec2 size = scene.camera.camera.viewport_size;
    for (uint s = 0u; s < GTAO_STEPS; ++s) {
        float t = (float(s) + jitter) / float(GTAO_STEPS);
        vec2 q = vec2(px) + 0.5 + dir * (t * t * radius_px + 1.0);
        if (any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, size))) break;
        float d = texelFetch(depth_target, ivec2(q), 0).r;
        if (d <= 0.0) continue;   // sky: no occluder
        vec3 delta = world_from_depth(floor(q), d) - p;
        float distance = length(delta);
        if (distance < 1e-5) continue;
        // XeGTAO's falloff: full weight to 38.5 % of the radius, none at it.
        float weight = clamp((radius - distance) / (0.615 * radius), 0.0, 1.0);
        horizon = max(horizon, mix(low, dot(delta / distance, v), weight));
    }
    return horizon;
}

float occlusion_at(ivec2 px, float depth, vec3 p, vec3 n) {
    GpuLighting l = scene.lighting.lighting;
    vec3 v = normalize(scene.camera.camera.position - p);
    float radius = l.occlusion_radius;
    // The radius in pixels at this depth: the world size of a pixel here, from its neighbour at
    // the same depth.
    float pixel_world = length(world_from_depth(vec2(px) + vec2(1.0, 0.0), depth) - p);
    float radius_px = min(radius / max(pixel_world, 1e-6), 256.0);
    if (radius_px < 1.0) return 1.0;
    uint pattern = occlusion_pattern(px);
    float visibility = 0.0;
    for (uint slice = 0u; slice < GTAO_SLICES; ++slice) {
        float angle = PI * (float(pattern * GTAO_SLICES + slice) + 0.5) / float(16u * GTAO_SLICES);
        vec2 omega = vec2(cos(angle), sin(angle));
        // The slice's direction in the world: towards the pixel one step along omega, at this
        // depth (rows grow downwards on screen; world_from_depth knows).
        vec3 direction = safe_normalize(world_from_depth(vec2(px) + omega, depth) - p, vec3(1.0, 0.0, 0.0));
        vec3 ortho = safe_normalize(direction - v * dot(direction, v), vec3(1.0, 0.0, 0.0));
        vec3 axis = cross(ortho, v);
        vec3 projected = n - axis * dot(n, axis);
        float projected_length = length(projected);
        if (projected_length < 1e-4) { visibility += 1.0; continue; }
        float cos_n = clamp(dot(projected, v) / projected_length, -1.0, 1.0);
        float angle_n = sign(dot(ortho, projected)) * acos(cos_n);
        float jitter = fract(float(pattern) * 0.618034 + float(slice) * 0.5);
        // Angles grow towards +omega: the lowest horizons lie a quarter turn either side of
        // the projected normal.
        float cos_plus = gtao_horizon(px, p, v, omega, radius_px, radius, cos(angle_n + 0.5 * PI), jitter);
        float cos_minus = gtao_horizon(px, p, v, -omega, radius_px, radius, cos(angle_n - 0.5 * PI), jitter);
        float h_minus = angle_n + max(-acos(cos_minus) - angle_n, -0.5 * PI);
        float h_plus = angle_n + min(acos(cos_plus) - angle_n, 0.5 * PI);
        float sin_n = sin(angle_n);
        float arc_minus = (cos_n + 2.0 * h_minus * sin_n - cos(2.0 * h_minus - angle_n)) * 0.25;
        float arc_plus = (cos_n + 2.0 * h_plus * sin_n - cos(2.0 * h_plus - angle_n)) * 0.25;
        visibility += projected_length * (arc_minus + arc_plus);
    }
    return clamp(visibility / float(GTAO_SLICES), 0.0, 1.0);
}
#else
vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax);

float occlusion_at(ivec2 px, float depth, vec3 p, vec3 n) {
    GpuLighting l = scene.lighting.lighting;
    uint rays = max(l.occlusion_rays, 1u);
    uint first = occlusion_pattern(px) * rays;
    mat3 frame = tangent_frame(n);
    vec3 origin = raster_origin(p, n);
    float open = 0.0;
    for (uint k = 0u; k < rays; ++k) {
        // Cosine-weighted: a uniform point of the disc lifted onto the hemisphere.
        vec2 u = hammersley(first + k, 16u * rays);
        float r = sqrt(u.x), phi = 2.0 * PI * u.y;
        vec3 dir = frame * vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
        open += luminance(shadow_ray_transmittance(origin, dir, 1e-3, l.occlusion_radius));
    }
    return open / float(rays);
}
#endif

// Writes the pixel's raw (noisy) occlusion; sky pixels are open.
void occlusion_pixel(ivec2 px) {
    if (!pixel_inside(px)) return;
    float depth = texelFetch(depth_target, px, 0).r;
    float open = 1.0;
    if (depth > 0.0) {
        vec3 p = world_from_depth(vec2(px), depth);
        open = occlusion_at(px, depth, p, normal_from_depth_improved(px, depth, p));
    }
    imageStore(occlusion_raw_out, px, vec4(open));
}

#endif
