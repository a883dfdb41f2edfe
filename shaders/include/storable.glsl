// What the HDR target (RGBA16F) can hold. Every pass that writes radiance into it writes it
// through storable_radiance, so that no frame passes on a value that is not finite (issue 55): a
// light of intensity 1e38 or a blinding environment is as bright as half floats go, never
// infinite (infinities meet zeros in the tone mapper and turn into NaN, a black picture). The
// tone mapper checks its input in debug builds (display.glsl).
#ifndef STORABLE_GLSL
#define STORABLE_GLSL

// The largest finite half float.
const float HDR_MAX = 65504.0;

// `c` as the HDR target can hold it: NaN is 0, everything else within ±HDR_MAX (so infinities
// are HDR_MAX). Ordinary radiance passes unchanged.
vec3 storable_radiance(vec3 c) {
    return clamp(mix(c, vec3(0.0), isnan(c)), vec3(-HDR_MAX), vec3(HDR_MAX));
}

#endif
