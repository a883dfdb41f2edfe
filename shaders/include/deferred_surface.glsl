// The deferred pipeline's surface at a pixel, rebuilt from depth and the G-buffer for its
// lighting pass (deferred_lighting.frag and .comp): false for sky.
#ifndef DEFERRED_SURFACE_GLSL
#define DEFERRED_SURFACE_GLSL

#include "scene.glsl"
#include "depth.glsl"
#include "shading.glsl"
#include "visibility.glsl"

bool deferred_surface(ivec2 px, out SurfaceInputs s) {
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) return false; // sky: the clear colour stays
    vec3 p = world_from_depth(vec2(px), depth);
    s.position = p;
    world_derivatives(px, depth, p, s.dpdx, s.dpdy);
    s.geometric_normal = safe_normalize(cross(s.dpdy, s.dpdx), vec3(0.0, 1.0, 0.0));
    vec4 albedo = texelFetch(gbuffer_albedo, px, 0);
    vec3 n = texelFetch(gbuffer_normal, px, 0).xyz * 2.0 - 1.0;
    vec2 rm = texelFetch(gbuffer_material, px, 0).rg;
    s.normal = safe_normalize(n, s.geometric_normal);
    if (dot(s.geometric_normal, s.normal) < 0.0) s.geometric_normal = -s.geometric_normal;
    s.albedo = albedo.rgb;
    s.occlusion = albedo.a;
    s.roughness = rm.r;
    s.metallic = rm.g;
    s.emissive = vec3(0.0); // written by the geometry pass
    uvec2 ids = texelFetch(gbuffer_layers, px, 0).rg;
    s.decal_layers = ids.x & 0xFFu;
    s.skinned = ids.y != 0u && rest_pose_of_pixel(px, ids.y - 1u, ids.x >> 8, s.geometric_normal, s.rest_position, s.rest_normal);
    return true;
}

#endif
