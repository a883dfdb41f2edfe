// Display transform: exposure then a tone mapper (`GpuLighting::tonemapper`): Khronos PBR
// Neutral (the default, which keeps base colours recognisable: glTF sample viewer), Hill's ACES
// fit, or AgX. Each returns linear display colour; the output target is sRGB, so the hardware
// encodes.
#ifndef COLOR_GLSL
#define COLOR_GLSL

#include "layout.glsl"  // TONEMAP_*

// Relative luminance of linear Rec. 709 radiance (the weights every pass that weighs colour by
// brightness uses).
float luminance(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

vec3 pbr_neutral(vec3 color) {
    const float start_compression = 0.8 - 0.04;
    const float desaturation = 0.15;
    float x = min(color.r, min(color.g, color.b));
    float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    color -= offset;
    float peak = max(color.r, max(color.g, color.b));
    if (peak < start_compression) return color;
    const float d = 1.0 - start_compression;
    float new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3(new_peak), g);
}

// Stephen Hill's fit of the ACES reference rendering and output transforms (sRGB, "ACESFitted"),
// after the customary 1/0.6 exposure bias.
vec3 aces_fitted(vec3 color) {
    // The fit's input and output matrices (column-major).
    const mat3 aces_input = mat3(0.59719, 0.07600, 0.02840, 0.35458, 0.90834, 0.13383, 0.04823, 0.01566, 0.83777);
    const mat3 aces_output = mat3(1.60475, -0.10208, -0.00327, -0.53108, 1.10813, -0.07276, -0.07367, -0.00605, 1.07602);
    vec3 v = aces_input * (color / 0.6);
    vec3 a = v * (v + 0.0245786) - 0.000090537;
    vec3 b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return clamp(aces_output * (a / b), 0.0, 1.0);
}

// AgX (Troy Sobotka) in Benjamin Wrensch's minimal fit: the inset matrix, a log2 encoding over
// [−12.47, 4.03] EV, the default-look sigmoid as a sixth-order polynomial, the outset matrix,
// then the 2.2 power back to linear.
vec3 agx(vec3 color) {
    const mat3 inset = mat3(0.842479062253094, 0.0423282422610123, 0.0423756549057051,
                            0.0784335999999992, 0.878468636469772, 0.0784336,
                            0.0792237451477643, 0.0791661274605434, 0.879142973793104);
    const mat3 outset = mat3(1.19687900512017, -0.0528968517574562, -0.0529716355144438,
                             -0.0980208811401368, 1.15190312990417, -0.0980434501171241,
                             -0.0990297440797205, -0.0989611768448433, 1.15107367264116);
    const float min_ev = -12.47393;
    const float max_ev = 4.026069;
    vec3 x = clamp(log2(max(inset * color, vec3(1e-10))), min_ev, max_ev);
    x = (x - min_ev) / (max_ev - min_ev);
    vec3 x2 = x * x;
    vec3 x4 = x2 * x2;
    x = 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232;
    return pow(clamp(outset * x, 0.0, 1.0), vec3(2.2));
}

// Linear radiance × exposure to linear display colour, by the tone mapper `tonemapper`.
vec3 tonemap(vec3 color, uint tonemapper) {
    if (tonemapper == TONEMAP_ACES_FITTED) return aces_fitted(color);
    if (tonemapper == TONEMAP_AGX) return agx(color);
    return pbr_neutral(color);
}

#endif
