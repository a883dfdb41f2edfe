// The visibility buffer's surface at a pixel: the ids' triangle intersected by the camera ray
// (visibility.glsl, with analytic derivatives) and its material sampled, for the shading pass
// (visbuffer_shade.frag and .comp): false for sky. The reflection pass samples the surfaces its
// rays hit through the same `surface_inputs`.
#ifndef VISBUFFER_SURFACE_GLSL
#define VISBUFFER_SURFACE_GLSL

#include "scene.glsl"
#include "visibility.glsl"
#include "material.glsl"
#include "shading.glsl"
#include "lod_debug.glsl"

// The shading inputs of a rebuilt surface: its material sampled with its analytic gradients.
SurfaceInputs surface_inputs(VisibleSurface v) {
    SurfaceInputs s;
    GpuMaterial m = v.material;
    MaterialSample ms = sample_material(m, v.uv, v.duvdx, v.duvdy);
    s.position = v.position;
    s.dpdx = v.dpdx;
    s.dpdy = v.dpdy;
    s.geometric_normal = v.geometric_normal;
    s.normal = perturb_normal(v.geometric_normal, v.tangent, ms.tangent_normal, m.normal_scale);
    s.albedo = ms.base.rgb;
    s.roughness = ms.roughness;
    s.metallic = ms.metallic;
    s.occlusion = ms.occlusion;
    s.emissive = ms.emissive;
    s.decal_layers = v.instance.decal_layers;
    s.skinned = v.skinned;
    s.rest_position = v.rest_position;
    s.rest_normal = v.rest_normal;
    return s;
}

bool visbuffer_surface(ivec2 px, out SurfaceInputs s) {
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) return false; // sky: the clear colour stays
    uvec2 ids = texelFetch(visibility_ids, px, 0).rg;
    s = surface_inputs(visible_surface(px, ids));
    if (scene.debug_view == DEBUG_LOD) s.albedo = lod_color(lod_level_of(ids.x, ids.y));
    return true;
}

#endif
