// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Forward shading pass (depth test EQUAL against the prepass): the material through the
// bindless array, normal mapping, then shade_surface (ray-query decals and every light).
#include "scene.glsl"
#include "mesh_io.glsl"
#include "material.glsl"
#include "shading.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    GpuMaterial m = scene.materials.materials[v_material];
    // Derivatives first, in uniform control flow: the decal loop cannot take them (§4.1.3).
    vec3 dpdx = dFdx(v_world_pos);
    vec3 dpdy = dFdy(v_world_pos);
    MaterialSample ms = sample_material(m, v_uv, dFdx(v_uv), dFdy(v_uv));

    vec3 geometric_n = safe_normalize(v_normal, vec3(0.0, 1.0, 0.0));
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !gl_FrontFacing) geometric_n = -geometric_n;

    SurfaceInputs s;
    s.position = v_world_pos;
    s.dpdx = dpdx;
    s.dpdy = dpdy;
    s.geometric_normal = geometric_n;
    s.normal = perturb_normal(geometric_n, v_tangent, ms.tangent_normal, m.normal_scale);
    s.albedo = ms.base.rgb;
    s.roughness = ms.roughness;
    s.metallic = ms.metallic;
    s.occlusion = ms.occlusion;
    s.emissive = ms.emissive;
    s.decal_layers = scene.instances.instances[v_instance].decal_layers;
    out_color = shade_surface(s, ivec2(gl_FragCoord.xy));
}
