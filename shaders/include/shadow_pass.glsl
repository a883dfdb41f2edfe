// Ray-traced hard shadows (seed 001 §4.3), per pixel and from depth alone, so one pass serves
// every pipeline: the world position from depth (seed alg. 4.1, `world_from_depth`), the normal
// from depth (depth_normals.glsl, naive or improved), then for each light of the pixel's list
// one shadow ray towards it, unless no light reaches the point (out of range, outside a spot's
// cone) or, with shadow-ray culling, the normal faces away from it. Bit k of a row's word is
// set when entry 32·row + k reaches the pixel unblocked (light_tiles.glsl).
//
// The including shader defines how a ray is traced (ray query or traceRayEXT):
//   bool shadow_ray_unblocked(vec3 origin, vec3 dir, float tmin, float tmax);
// Rays follow the seed: tmin 0.001, tmax the distance to the light (1000 for directional
// lights), first hit ends the ray. The origin is lifted off the surface along the
// reconstructed normal by 0.1 % of its distance to the camera, so that depth quantisation
// cannot put it under its own surface.
#ifndef SHADOW_PASS_GLSL
#define SHADOW_PASS_GLSL

#include "scene.glsl"
#include "lighting.glsl"
#include "depth_normals.glsl"
#include "light_tiles.glsl"

layout(set = 0, binding = BINDING_SHADOW_DEBUG, rgba16f) uniform writeonly image2D shadow_debug_out;

bool shadow_ray_unblocked(vec3 origin, vec3 dir, float tmin, float tmax);

void shadow_pixel(ivec2 px) {
    GpuLighting l = scene.lighting.lighting;
    if (!pixel_inside(px)) return;
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) return;
    vec3 p = world_from_depth(vec2(px), depth);
    vec3 n = (l.flags & SHADOW_NORMALS_IMPROVED) != 0u ? normal_from_depth_improved(px, depth, p)
                                                        : normal_from_depth_naive(px, depth, p);
    LightList list = light_list(px);
    uint rays = 0u;
    if (list.rows != NO_SHADOW_ROWS) {
        bool cull = (l.flags & SHADOW_RAY_CULLING) != 0u;
        vec3 origin = shadow_origin(p, n);
        ShadowWordsRef words = ShadowWordsRef(l.shadow_bits);
        for (uint base = 0u; base < list.count; base += 32u) {
            uint word = 0u;
            uint here = min(32u, list.count - base);
            for (uint k = 0u; k < here; ++k) {
                GpuLight light = scene.lights.lights[light_slot(list, base + k)];
                vec3 dir;
                float tmax;
                if (!shadow_ray_towards(light, p, dir, tmax)) continue;
                if (cull && dot(n, dir) <= 0.0) continue;
                ++rays;
                if (shadow_ray_unblocked(origin, dir, 1e-3, tmax)) word |= 1u << k;
            }
            words.words[shadow_word_at(list, base, px)] = word;
        }
    }
    if ((l.flags & SHADOW_DEBUG) != 0u) imageStore(shadow_debug_out, px, vec4(n * 0.5 + 0.5, float(rays)));
}

#endif
