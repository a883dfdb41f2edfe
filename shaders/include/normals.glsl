// Tangent-space normal mapping with the MikkTSpace convention (bitangent = sign × cross(n, t)).
#ifndef NORMALS_GLSL
#define NORMALS_GLSL

vec3 perturb_normal(vec3 n, vec4 tangent, vec3 tangent_space_normal, float scale) {
    vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
    float tl = length(t);
    if (tl < 1e-6) return n;
    t /= tl;
    vec3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);
    vec3 ts = vec3(tangent_space_normal.xy * scale, tangent_space_normal.z);
    vec3 perturbed = mat3(t, b, n) * ts;
    float len2 = dot(perturbed, perturbed);
    // A texel of (0.5, 0.5, 0.5) encodes no direction at all; keep the geometric normal.
    return len2 > 1e-12 ? perturbed * inversesqrt(len2) : n;
}

vec3 safe_normalize(vec3 v, vec3 fallback) {
    float l2 = dot(v, v);
    return l2 > 1e-12 ? v * inversesqrt(l2) : fallback;
}

// A tangent-space normal from a normal map's texel. A two-channel map (BC5, which samples its
// blue channel as 0) holds only X and Y: Z is rebuilt from them. A three-channel texel never has
// blue 0 (it would point straight into the surface), so it decodes as it always did.
vec3 decode_normal_texel(vec3 texel) {
    vec3 n = texel * 2.0 - 1.0;
    if (texel.z == 0.0) n.z = sqrt(max(0.0, 1.0 - dot(n.xy, n.xy)));
    return n;
}

// An orthonormal frame whose third column is the unit vector `n` (tangent, bitangent, n).
mat3 tangent_frame(vec3 n) {
    vec3 t = normalize(abs(n.z) < 0.999 ? cross(vec3(0.0, 0.0, 1.0), n) : cross(vec3(1.0, 0.0, 0.0), n));
    return mat3(t, cross(n, t), n);
}

#endif
