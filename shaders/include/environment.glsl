// Image-based light (render/src/environment): the environment's diffuse irradiance from nine
// spherical-harmonic coefficients, its specular radiance from the GGX-prefiltered cube, and
// Karis's split sum (2013) with Fdez-Agüera's multiple-scattering energy compensation (2019) over
// the BRDF table, so that a white furnace holds; specular occlusion from the material's
// occlusion (Lagarde and de Rousiers 2014, §4.10.2). Without an environment the flat ambient
// colour stands in, as before.
#ifndef ENVIRONMENT_GLSL
#define ENVIRONMENT_GLSL

#include "scene.glsl"
#include "brdf.glsl"

layout(set = 0, binding = BINDING_ENVIRONMENT) uniform samplerCube environment_specular;
layout(set = 0, binding = BINDING_BRDF_LUT) uniform sampler2D brdf_lut;
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer EnvironmentRef { GpuEnvironment environment; };

bool environment_on() {
    return (scene.lighting.lighting.environment_flags & ENVIRONMENT_ON) != 0u;
}

// A world direction in the environment's frame (the environment turned about +Y).
vec3 environment_direction(vec3 d) {
    vec2 cs = scene.lighting.lighting.environment_rotation;
    return vec3(cs.x * d.x - cs.y * d.z, d.y, cs.y * d.x + cs.x * d.z);
}

// The nine real spherical harmonics of bands 0–2 at unit direction `d`.
void sh9_basis(vec3 d, out float y[9]) {
    y[0] = 0.282095;
    y[1] = 0.488603 * d.y;
    y[2] = 0.488603 * d.z;
    y[3] = 0.488603 * d.x;
    y[4] = 1.092548 * d.x * d.y;
    y[5] = 1.092548 * d.y * d.z;
    y[6] = 0.315392 * (3.0 * d.z * d.z - 1.0);
    y[7] = 1.092548 * d.x * d.z;
    y[8] = 0.546274 * (d.x * d.x - d.y * d.y);
}

// Irradiance / π at a surface facing `n` (the radiance a white Lambertian surface reflects).
vec3 environment_irradiance(vec3 n) {
    EnvironmentRef env = EnvironmentRef(scene.lighting.lighting.environment);
    float y[9];
    sh9_basis(environment_direction(n), y);
    vec3 e = vec3(0.0);
    for (int i = 0; i < 9; ++i) e += env.environment.sh[i].rgb * y[i];
    return max(e, vec3(0.0)) * scene.lighting.lighting.environment_intensity;
}

// The environment's radiance towards `-dir`, prefiltered for a surface of perceptual
// roughness `roughness` (0: the sharp environment).
vec3 environment_radiance(vec3 dir, float roughness) {
    GpuLighting l = scene.lighting.lighting;
    return textureLod(environment_specular, environment_direction(dir), roughness * l.environment_max_level).rgb * l.environment_intensity;
}

// Specular occlusion from ambient occlusion (Lagarde and de Rousiers 2014, eq. 58).
float specular_occlusion(float n_dot_v, float occlusion, float alpha) {
    return clamp(pow(n_dot_v + occlusion, exp2(-16.0 * alpha - 1.0)) - 1.0 + occlusion, 0.0, 1.0);
}

// The split sum's scale and bias of F0 for this surface and view (the BRDF table).
vec2 environment_brdf(float n_dot_v, float roughness) {
    return textureLod(brdf_lut, vec2(n_dot_v, roughness), 0.0).rg;
}

// How much of the environment's prefiltered radiance in the mirror direction the surface
// reflects (single scattering × specular occlusion): what reflections replace.
vec3 ambient_specular_weight(SurfaceBrdf brdf, vec3 n, vec3 v, float occlusion) {
    float n_dot_v = clamp(dot(n, v), 1e-4, 1.0);
    if (!environment_on()) return env_brdf_approx(brdf.f0, brdf.roughness, n_dot_v) * occlusion;
    vec2 ab = environment_brdf(n_dot_v, brdf.roughness);
    return (brdf.f0 * ab.x + ab.y) * specular_occlusion(n_dot_v, occlusion, brdf.alpha);
}

// What reflections replace at a surface reflecting towards `r`: the environment's prefiltered
// radiance there, or the flat ambient colour.
vec3 ambient_specular(vec3 r, float roughness) {
    return environment_on() ? environment_radiance(r, roughness) : scene.camera.camera.ambient;
}

// The light a surface receives from its surroundings: the environment (diffuse, specular and
// the multiply scattered specular energy) or the flat ambient colour.
vec3 ambient_light(SurfaceBrdf brdf, vec3 n, vec3 v, float occlusion) {
    if (!environment_on()) return scene.camera.camera.ambient * (brdf.diffuse_color + brdf.f0) * occlusion;
    float n_dot_v = clamp(dot(n, v), 1e-4, 1.0);
    vec2 ab = environment_brdf(n_dot_v, brdf.roughness);
    vec3 fss_ess = brdf.f0 * ab.x + ab.y;
    float ems = 1.0 - ab.x - ab.y;
    vec3 f_avg = brdf.f0 + (1.0 - brdf.f0) / 21.0;
    vec3 fms_ems = ems * fss_ess * f_avg / (1.0 - f_avg * ems);
    vec3 kd = brdf.diffuse_color * (1.0 - fss_ess - fms_ems);
    vec3 specular = fss_ess * environment_radiance(reflect(-v, n), brdf.roughness) * specular_occlusion(n_dot_v, occlusion, brdf.alpha);
    return specular + (fms_ems + kd) * environment_irradiance(n) * occlusion;
}

// Radiance from the environment (or the clear colour) along a ray that hits nothing.
vec3 sky_along(vec3 dir) {
    return environment_on() ? environment_radiance(dir, 0.0) : scene.lighting.lighting.clear_color.rgb;
}

#endif
