// Shading shared by every pipeline: given a surface's attributes (from the forward pass's
// varyings, the G-buffer, or the visibility buffer's reconstruction), apply decals, answer the
// debug views, and light it. Decals come from in-shader ray queries (RAY_QUERY_DECALS variants)
// or from the decal buffer a decal pass wrote (DECAL_BUFFER variants), when the frame has any.
#ifndef SHADING_GLSL
#define SHADING_GLSL

#include "scene.glsl"
#include "lighting.glsl"
#include "decals.glsl"
#include "heatmap.glsl"
#ifdef DECAL_BUFFER
#include "decal_buffer.glsl"
#endif

struct SurfaceInputs {
    vec3 position;
    vec3 dpdx;              // world-position derivatives (for decal mip selection)
    vec3 dpdy;
    vec3 geometric_normal;  // for the decal angle fade
    vec3 normal;            // shading normal (normal-mapped)
    vec3 albedo;
    float roughness;
    float metallic;
    float occlusion;
    vec3 emissive;
    uint decal_layers;
};

vec4 shade_surface(SurfaceInputs s) {
    uint decals_tested = 0u;
#ifdef RAY_QUERY_DECALS
    if (scene.decal_count > 0u) {
        DecalSurface surface;
        surface.position = s.position;
        surface.dpdx = s.dpdx;
        surface.dpdy = s.dpdy;
        surface.geometric_normal = s.geometric_normal;
        surface.normal = s.normal;
        surface.layers = s.decal_layers;
        DecalBlend blend;
        blend_init(blend);
        decals_tested = gather_decals(blend, surface);
        blend_resolve(blend, s.albedo, s.normal, s.roughness, s.metallic);
    }
#endif
#ifdef DECAL_BUFFER
    if (scene.decal_count > 0u) decals_tested = decal_buffer_apply(ivec2(gl_FragCoord.xy), s.albedo, s.normal, s.roughness, s.metallic);
#endif
    if (scene.debug_view == DEBUG_ALBEDO) return vec4(s.albedo, 1.0);
    if (scene.debug_view == DEBUG_NORMAL) return vec4(s.normal * 0.5 + 0.5, 1.0);
    if (scene.debug_view == DEBUG_ROUGHNESS_METALLIC) return vec4(s.roughness, s.metallic, 0.0, 1.0);
    if (scene.debug_view == DEBUG_DECAL_COUNT) return vec4(float(decals_tested), 0.0, 0.0, 1.0);
    if (scene.debug_view == DEBUG_DECAL_HEATMAP) return vec4(heatmap(float(decals_tested) / 16.0), 1.0);

    GpuCamera cam = scene.camera.camera;
    vec3 v = normalize(cam.position - s.position);
    SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
    vec3 color = s.emissive + cam.ambient * (brdf.diffuse_color + brdf.f0) * s.occlusion;
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight light = scene.lights.lights[i];
        if (light.kind == LIGHT_NONE) continue;
        color += shade_light(light, brdf, s.position, s.normal, v);
    }
    return vec4(color, 1.0);
}

#endif
