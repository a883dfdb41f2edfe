// Auto-exposure (render/src/exposure): the record its passes keep, the histogram's bins, and the
// exposure the display transform applies.
#ifndef EXPOSURE_GLSL
#define EXPOSURE_GLSL

#include "scene.glsl"
#include "color.glsl"

layout(buffer_reference, std430, buffer_reference_align = 16) buffer ExposureRef { GpuExposure exposure; };

// The histogram bin of luminance `l`: 0 for black and what is darker than the range, then
// EXPOSURE_BINS − 1 equal steps of log2 luminance (the brightest bin takes everything above).
uint exposure_bin(float l) {
    float t = (log2(max(l, 1e-30)) + float(EXPOSURE_LOG2_OFFSET)) / float(EXPOSURE_LOG2_RANGE);
    if (t <= 0.0) return 0u;
    return 1u + min(uint(t * float(EXPOSURE_BINS - 1u)), EXPOSURE_BINS - 2u);
}

// log2 luminance at the centre of bin `b` (b ≥ 1).
float exposure_bin_log2(uint b) {
    return (float(b) - 0.5) / float(EXPOSURE_BINS - 1u) * float(EXPOSURE_LOG2_RANGE) - float(EXPOSURE_LOG2_OFFSET);
}

// The exposure the display transform applies: auto-exposure's once it has adapted, else the
// camera's.
float display_exposure() {
    uint64_t address = scene.lighting.lighting.exposure;
    if (address != 0ul) {
        float e = ExposureRef(address).exposure.exposure;
        if (e > 0.0) return e;
    }
    return scene.camera.camera.exposure;
}

#endif
