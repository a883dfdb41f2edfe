#version 460
// The split sum's BRDF table (Karis 2013, "Real Shading in Unreal Engine 4"): for n·v (x) and
// perceptual roughness (y) at texel centres, the scale A and bias B of F0 in ∫ f·(n·l) dl =
// F0·A + B, integrated by GGX importance sampling with our height-correlated Smith visibility
// (brdf.glsl), so that the environment's specular matches the lights'. Written once.
#include "scene.glsl"
#include "brdf.glsl"

layout(set = 0, binding = BINDING_BRDF_LUT_STORAGE, rg16f) uniform writeonly image2D brdf_lut_out;
layout(local_size_x = 8, local_size_y = 8) in;

const uint LUT_SAMPLES = 512u;

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(px, uvec2(BRDF_LUT_SIZE)))) return;
    float n_dot_v = (float(px.x) + 0.5) / float(BRDF_LUT_SIZE);
    float roughness = max((float(px.y) + 0.5) / float(BRDF_LUT_SIZE), 0.045);
    float alpha = roughness * roughness;
    vec3 v = vec3(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    vec2 ab = vec2(0.0);
    for (uint i = 0u; i < LUT_SAMPLES; ++i) {
        vec3 h = sample_ggx_ndf(hammersley(i, LUT_SAMPLES), alpha);
        vec3 l = reflect(-v, h);
        float n_dot_l = l.z;
        if (n_dot_l <= 0.0) continue;
        float v_dot_h = clamp(dot(v, h), 0.0, 1.0);
        // f·(n·l) / pdf with pdf = D (n·h) / (4 v·h): the visibility term times 4 (n·l)(v·h)/(n·h).
        float g = v_smith_ggx_correlated(n_dot_v, n_dot_l, alpha) * 4.0 * n_dot_l * v_dot_h / max(h.z, 1e-6);
        float fc = pow(1.0 - v_dot_h, 5.0);
        ab += vec2(1.0 - fc, fc) * g;
    }
    imageStore(brdf_lut_out, ivec2(px), vec4(ab / float(LUT_SAMPLES), 0.0, 0.0));
}
