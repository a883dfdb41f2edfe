// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Visibility-buffer deferred texturing, shading pass (seed 000 §5.1.3): each pixel rebuilds its
// surface from the ids (include/visibility.glsl, with analytic derivatives), samples its
// material and shades it.
#include "scene.glsl"
#include "visibility.glsl"
#include "material.glsl"
#include "shading.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) discard; // sky: the clear colour stays
    VisibleSurface v = visible_surface(px, texelFetch(visibility_ids, px, 0).rg);
    GpuMaterial m = v.material;
    MaterialSample ms = sample_material(m, v.uv, v.duvdx, v.duvdy);

    SurfaceInputs s;
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
    out_color = shade_surface(s);
}
