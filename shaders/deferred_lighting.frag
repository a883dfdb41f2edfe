// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Deferred shading, lighting pass (seed 000 §5.1.2): one full-screen pass reads the G-buffer,
// applies ray-query decals to the attributes, lights them, and adds the result to the emitted
// radiance already in the HDR target.
#include "scene.glsl"
#include "depth.glsl"
#include "shading.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) discard; // sky: the clear colour stays
    vec3 p = world_from_depth(vec2(px), depth);
    SurfaceInputs s;
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
    s.decal_layers = texelFetch(gbuffer_layers, px, 0).r;
    out_color = shade_surface(s);
}
