// Reads a metallic-roughness material at a UV, with explicit gradients so the same code serves
// rasterised passes (hardware derivatives) and the visibility buffer (analytic ones).
#ifndef MATERIAL_GLSL
#define MATERIAL_GLSL

#include "scene.glsl"
#include "normals.glsl"

struct MaterialSample {
    vec4 base;          // linear colour and alpha
    float metallic;
    float roughness;
    float occlusion;
    vec3 emissive;
    vec3 tangent_normal; // decoded normal-map texel
};

vec4 sample_grad(uint index, vec2 uv, vec2 dx, vec2 dy) {
    return textureGrad(textures[nonuniformEXT(index)], uv, dx, dy);
}

MaterialSample sample_material(GpuMaterial m, vec2 uv, vec2 duvdx, vec2 duvdy) {
    MaterialSample s;
    s.base = m.base_color * sample_grad(m.base_color_tex, uv, duvdx, duvdy);
    vec2 mr = sample_grad(m.metallic_roughness_tex, uv, duvdx, duvdy).bg;
    s.metallic = m.metallic * mr.x;
    s.roughness = m.roughness * mr.y;
    s.occlusion = mix(1.0, sample_grad(m.occlusion_tex, uv, duvdx, duvdy).r, m.occlusion_strength);
    s.emissive = m.emissive * sample_grad(m.emissive_tex, uv, duvdx, duvdy).rgb;
    s.tangent_normal = decode_normal_texel(sample_grad(m.normal_tex, uv, duvdx, duvdy).xyz);
    return s;
}

#endif
