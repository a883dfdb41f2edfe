// The Frostbite standard material (seed 000 §2.3; Lagarde and de Rousiers 2014): GGX normal
// distribution, height-correlated Smith visibility, Schlick Fresnel, renormalised Disney diffuse.
// tests/tests/brdf.rs evaluates the same equations on the CPU and compares against the GPU.
#ifndef BRDF_GLSL
#define BRDF_GLSL

const float PI = 3.14159265358979;
// Seed 000 §2.3: "a constant value of 0.02 for all non metals".
const float DIELECTRIC_F0 = 0.02;

// x⁵ by three multiplications, whatever the driver makes of pow(x, 5.0) (exp2(5 log2 x) where it
// does not see the integer; NVIDIA's does: the many-lights scene's shading measured the same
// either way on the H200), and exact at x = 0.
float pow5(float x) {
    float x2 = x * x;
    return x2 * x2 * x;
}

vec3 f_schlick(vec3 f0, float f90, float u) {
    return f0 + (vec3(f90) - f0) * pow5(1.0 - u);
}

float f_schlick1(float f0, float f90, float u) {
    return f0 + (f90 - f0) * pow5(1.0 - u);
}

// GGX / Trowbridge-Reitz normal distribution; alpha = roughness².
float d_ggx(float n_dot_h, float alpha) {
    float a2 = alpha * alpha;
    float f = (n_dot_h * a2 - n_dot_h) * n_dot_h + 1.0;
    return a2 / (PI * f * f);
}

// Height-correlated Smith G divided by 4|n·l||n·v| (Heitz 2014, Frostbite eq. 5.1.2).
float v_smith_ggx_correlated(float n_dot_v, float n_dot_l, float alpha) {
    float a2 = alpha * alpha;
    float lambda_v = n_dot_l * sqrt((-n_dot_v * a2 + n_dot_v) * n_dot_v + a2);
    float lambda_l = n_dot_v * sqrt((-n_dot_l * a2 + n_dot_l) * n_dot_l + a2);
    return 0.5 / (lambda_v + lambda_l);
}

// Renormalised Disney diffuse (Frostbite listing 1), without the 1/π.
float fd_disney_renormalized(float n_dot_v, float n_dot_l, float l_dot_h, float linear_roughness) {
    float energy_bias = mix(0.0, 0.5, linear_roughness);
    float energy_factor = mix(1.0, 1.0 / 1.51, linear_roughness);
    float fd90 = energy_bias + 2.0 * l_dot_h * l_dot_h * linear_roughness;
    float light_scatter = f_schlick1(1.0, fd90, n_dot_l);
    float view_scatter = f_schlick1(1.0, fd90, n_dot_v);
    return light_scatter * view_scatter * energy_factor;
}

struct SurfaceBrdf {
    vec3 diffuse_color;   // base colour × (1 − metallic)
    vec3 f0;              // mix(DIELECTRIC_F0, base colour, metallic)
    float roughness;      // perceptual ("linear") roughness
    float alpha;          // roughness²
};

SurfaceBrdf surface_brdf(vec3 base_color, float metallic, float roughness) {
    SurfaceBrdf s;
    s.roughness = clamp(roughness, 0.045, 1.0);  // keeps GGX finite for mirror-like surfaces
    s.alpha = s.roughness * s.roughness;
    s.diffuse_color = base_color * (1.0 - metallic);
    s.f0 = mix(vec3(DIELECTRIC_F0), base_color, metallic);
    return s;
}

// f(l, v) · (n·l): the reflected radiance per unit incident irradiance-from-normal-direction.
// n, v and l are unit vectors (the half vector's cosines below rely on it).
vec3 brdf_cos(SurfaceBrdf s, vec3 n, vec3 v, vec3 l) {
    float n_dot_l = clamp(dot(n, l), 0.0, 1.0);
    if (n_dot_l <= 0.0) return vec3(0.0);
    // The half vector h = (v + l) / |v + l| enters only through its cosines, so it is never
    // formed: for unit v and l, |v + l|² = 2 + 2 v·l, n·h = (n·l + n·v) / |v + l| and
    // l·h = (1 + v·l) / |v + l|. One reciprocal square root instead of a normalisation and two
    // dot products; where v = −l (h undefined) both cosines are 0 instead of NaN.
    float v_dot_l = dot(v, l);
    float inv_len_h = inversesqrt(max(2.0 + 2.0 * v_dot_l, 1e-12));
    float n_dot_v_signed = dot(n, v);
    // Frostbite adds 1e-5 to avoid a zero; the clamp keeps 1 − n·v within [0, 1].
    float n_dot_v = min(abs(n_dot_v_signed) + 1e-5, 1.0);
    float n_dot_h = clamp((n_dot_l + n_dot_v_signed) * inv_len_h, 0.0, 1.0);
    float l_dot_h = clamp((1.0 + v_dot_l) * inv_len_h, 0.0, 1.0);

    vec3 f = f_schlick(s.f0, 1.0, l_dot_h);
    float vis = v_smith_ggx_correlated(n_dot_v, n_dot_l, s.alpha);
    float d = d_ggx(n_dot_h, s.alpha);
    vec3 fr = d * vis * f;
    vec3 fd = s.diffuse_color * (fd_disney_renormalized(n_dot_v, n_dot_l, l_dot_h, s.roughness) / PI);
    return (fr + fd) * n_dot_l;
}

// The specular reflectance integrated over the GGX lobe (the split sum's second factor), from
// Karis's analytic fit ("Physically Based Shading on Mobile", 2014): what a reflection seen
// along the lobe is weighted by, f0 × a + b.
vec3 env_brdf_approx(vec3 f0, float roughness, float n_dot_v) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * n_dot_v)) * r.x + r.y;
    vec2 ab = vec2(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + ab.y;
}

// A microfacet normal drawn from the GGX distribution of visible normals (Heitz 2018, "Sampling
// the GGX Distribution of Visible Normals"), for view direction `v` in the tangent frame whose z
// is the surface normal; `u` two uniform numbers in [0, 1).
vec3 sample_ggx_vndf(vec3 v, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * v.x, alpha * v.y, v.z));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(0.0, nh.z)));
}

// Point `i` of `n` of the Hammersley set in [0, 1)² (the split-sum integrals' low-discrepancy
// samples).
vec2 hammersley(uint i, uint n) {
    return vec2((float(i) + 0.5) / float(n), float(bitfieldReverse(i)) * (1.0 / 4294967296.0));
}

// A half vector drawn from the GGX distribution D(h)·(n·h) around +Z (Karis 2013, "Real Shading
// in Unreal Engine 4"); its pdf for the reflected direction is D·(n·h) / (4 v·h).
vec3 sample_ggx_ndf(vec2 u, float alpha) {
    float phi = 2.0 * PI * u.x;
    float cos_theta = sqrt((1.0 - u.y) / (1.0 + (alpha * alpha - 1.0) * u.y));
    float sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

#endif
