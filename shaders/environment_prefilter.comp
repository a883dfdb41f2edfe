#version 460
// One level of the environment's specular cube (render/src/environment): the radiance a
// surface of perceptual roughness level / (levels − 1) reflects, under the split sum's n = v = r
// assumption (Karis 2013), by GGX importance sampling with each sample read from the radiance
// cube's level whose texels match the sample's solid angle (Křivánek and Colbert 2008,
// "Real-time Shading with Filtered Importance Sampling"), without their +1 level bias: with it
// the levels came out up to 12 % blurrier than the exact integral (tests/tests/environment.rs),
// without it within 4 %. Level 0 (roughness 0) is the sharp radiance. `scene.texture_index` is
// the level written.
#include "environment_levels.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

const uint PREFILTER_SAMPLES = 64u;

void main() {
    GpuEnvironmentJob env = environment_job();
    uint level = scene.texture_index;
    uvec3 texel;
    vec3 n;
    if (!level_texel(max(env.face >> level, 1u), texel, n)) return;
    ivec3 out_texel = ivec3(texel);
    uint view = ENVIRONMENT_SPECULAR_VIEWS + level;
    if (level == 0u) {
        imageStore(environment_levels[view], out_texel, vec4(textureLod(environment_source, n, 0.0).rgb, 1.0));
        return;
    }
    float roughness = float(level) / float(env.specular_levels - 1u);
    float alpha = max(roughness * roughness, 1e-4);
    mat3 frame = tangent_frame(n);
    float texel_solid_angle = 4.0 * PI / (6.0 * float(env.face * env.face));
    float top = float(env.source_levels - 1u);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (uint i = 0u; i < PREFILTER_SAMPLES; ++i) {
        vec3 h = frame * sample_ggx_ndf(hammersley(i, PREFILTER_SAMPLES), alpha);
        vec3 l = reflect(-n, h);
        float n_dot_l = dot(n, l);
        if (n_dot_l <= 0.0) continue;
        // pdf of l with v = n: D(h) (n·h) / (4 v·h) = D(h) / 4.
        float pdf = d_ggx(clamp(dot(n, h), 0.0, 1.0), alpha) * 0.25;
        float sample_solid_angle = 1.0 / (float(PREFILTER_SAMPLES) * pdf + 1e-6);
        float lod = clamp(0.5 * log2(sample_solid_angle / texel_solid_angle), 0.0, top);
        sum += textureLod(environment_source, l, lod).rgb * n_dot_l;
        weight += n_dot_l;
    }
    imageStore(environment_levels[view], out_texel, vec4(sum / max(weight, 1e-6), 1.0));
}
