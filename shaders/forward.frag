#version 460
// Forward shading pass (depth test EQUAL against the prepass): material textures through the
// bindless array, normal mapping, every light through the Frostbite BRDF.
#include "scene.glsl"
#include "mesh_io.glsl"
#include "lighting.glsl"
#include "normals.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    GpuCamera cam = scene.camera.camera;
    GpuMaterial m = scene.materials.materials[v_material];

    vec4 base = m.base_color * sample_texture(m.base_color_tex, v_uv);
    vec2 mr = sample_texture(m.metallic_roughness_tex, v_uv).bg;
    float metallic = m.metallic * mr.x;
    float roughness = m.roughness * mr.y;
    float occlusion = mix(1.0, sample_texture(m.occlusion_tex, v_uv).r, m.occlusion_strength);
    vec3 emissive = m.emissive * sample_texture(m.emissive_tex, v_uv).rgb;

    float nl = dot(v_normal, v_normal);
    vec3 n = nl > 1e-12 ? v_normal * inversesqrt(nl) : vec3(0.0, 1.0, 0.0);
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !gl_FrontFacing) n = -n;
    vec3 ts = decode_normal_texel(sample_texture(m.normal_tex, v_uv).xyz);
    n = perturb_normal(n, v_tangent, ts, m.normal_scale);

    vec3 v = normalize(cam.position - v_world_pos);
    SurfaceBrdf s = surface_brdf(base.rgb, metallic, roughness);

    vec3 color = emissive + cam.ambient * (s.diffuse_color + s.f0) * occlusion;
    for (uint i = 0u; i < scene.light_count; ++i) {
        GpuLight light = scene.lights.lights[i];
        if (light.kind == LIGHT_NONE) continue;
        color += shade_light(light, s, v_world_pos, n, v);
    }
    out_color = vec4(color, 1.0);
}
