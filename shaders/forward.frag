// variants: RAY_QUERY_DECALS
#version 460
// Forward shading pass (depth test EQUAL against the prepass): material textures through the
// bindless array, normal mapping, ray-query decals blended into the surface attributes (in the
// RAY_QUERY_DECALS variant), then every light through the Frostbite BRDF.
#include "scene.glsl"
#include "mesh_io.glsl"
#include "lighting.glsl"
#include "normals.glsl"
#include "decals.glsl"
#include "heatmap.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    GpuCamera cam = scene.camera.camera;
    GpuMaterial m = scene.materials.materials[v_material];
    // Derivatives first, in uniform control flow: the decal loop cannot take them (§4.1.3).
    vec3 dpdx = dFdx(v_world_pos);
    vec3 dpdy = dFdy(v_world_pos);

    vec4 base = m.base_color * sample_texture(m.base_color_tex, v_uv);
    vec2 mr = sample_texture(m.metallic_roughness_tex, v_uv).bg;
    float metallic = m.metallic * mr.x;
    float roughness = m.roughness * mr.y;
    float occlusion = mix(1.0, sample_texture(m.occlusion_tex, v_uv).r, m.occlusion_strength);
    vec3 emissive = m.emissive * sample_texture(m.emissive_tex, v_uv).rgb;

    float nl = dot(v_normal, v_normal);
    vec3 geometric_n = nl > 1e-12 ? v_normal * inversesqrt(nl) : vec3(0.0, 1.0, 0.0);
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !gl_FrontFacing) geometric_n = -geometric_n;
    vec3 ts = decode_normal_texel(sample_texture(m.normal_tex, v_uv).xyz);
    vec3 n = perturb_normal(geometric_n, v_tangent, ts, m.normal_scale);
    vec3 albedo = base.rgb;

    uint decals_tested = 0u;
#ifdef RAY_QUERY_DECALS
    if (scene.decal_count > 0u) {
        DecalSurface surface;
        surface.position = v_world_pos;
        surface.dpdx = dpdx;
        surface.dpdy = dpdy;
        surface.geometric_normal = geometric_n;
        surface.normal = n;
        surface.layers = scene.instances.instances[v_instance].decal_layers;
        DecalBlend blend;
        blend_init(blend);
        decals_tested = gather_decals(blend, surface);
        blend_resolve(blend, albedo, n, roughness, metallic);
    }
#endif

    if (scene.debug_view == DEBUG_ALBEDO) { out_color = vec4(albedo, 1.0); return; }
    if (scene.debug_view == DEBUG_NORMAL) { out_color = vec4(n * 0.5 + 0.5, 1.0); return; }
    if (scene.debug_view == DEBUG_ROUGHNESS_METALLIC) { out_color = vec4(roughness, metallic, 0.0, 1.0); return; }
    if (scene.debug_view == DEBUG_DECAL_COUNT) { out_color = vec4(float(decals_tested), 0.0, 0.0, 1.0); return; }
    if (scene.debug_view == DEBUG_DECAL_HEATMAP) { out_color = vec4(heatmap(float(decals_tested) / 16.0), 1.0); return; }

    vec3 v = normalize(cam.position - v_world_pos);
    SurfaceBrdf s = surface_brdf(albedo, metallic, roughness);

    vec3 color = emissive + cam.ambient * (s.diffuse_color + s.f0) * occlusion;
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight light = scene.lights.lights[i];
        if (light.kind == LIGHT_NONE) continue;
        color += shade_light(light, s, v_world_pos, n, v);
    }
    out_color = vec4(color, 1.0);
}
