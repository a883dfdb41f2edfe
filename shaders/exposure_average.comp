#version 460
// Auto-exposure, pass 2 (render/src/exposure): one workgroup reads the histogram (and clears it
// for the next frame), averages log2 luminance over the pixels between the 10th and 90th
// percentiles, ignoring black (a black sky, a few blinding highlights do not decide the
// exposure), and moves the scene's EV100 = log2(L · 100 / 12.5) (Lagarde and de Rousiers,
// "Moving Frostbite to PBR", 2014, §5.1) towards that average's by 1 − e^(−rate · dt); the
// exposure puts the average at 18 % grey, as Unreal's auto-exposure does:
// exposure = 0.18 / L = 1.44 / 2^EV100, times 2^compensation.
// The push constant's texture_index carries dt's bits.
#include "exposure.glsl"

layout(local_size_x = EXPOSURE_BINS) in;

shared uint counts[EXPOSURE_BINS];

const float LOW_PERCENTILE = 0.1;
const float HIGH_PERCENTILE = 0.9;
const float MID_GREY = 0.18;

void main() {
    GpuLighting l = scene.lighting.lighting;
    ExposureRef record = ExposureRef(l.exposure);
    uint i = gl_LocalInvocationIndex;
    counts[i] = record.exposure.histogram[i];
    record.exposure.histogram[i] = 0u;
    barrier();
    if (i != 0u) return;
    float total = 0.0;
    for (uint b = 0u; b < EXPOSURE_BINS; ++b) total += float(counts[b]);
    float low = LOW_PERCENTILE * total, high = HIGH_PERCENTILE * total;
    float below = 0.0, sum = 0.0, weight = 0.0;
    for (uint b = 0u; b < EXPOSURE_BINS; ++b) {
        float c = float(counts[b]);
        float inside = max(min(below + c, high) - max(below, low), 0.0);
        if (b > 0u) {
            sum += inside * exposure_bin_log2(b);
            weight += inside;
        }
        below += c;
    }
    if (weight <= 0.0) return;   // nothing but black: keep the exposure
    float log2_luminance = sum / weight;
    float target = clamp(log2_luminance + log2(100.0 / 12.5), l.exposure_min_ev100, l.exposure_max_ev100) - l.exposure_compensation;
    float dt = uintBitsToFloat(scene.texture_index);
    float ev100 = record.exposure.frames == 0u ? target : mix(record.exposure.ev100, target, 1.0 - exp(-l.exposure_rate * dt));
    record.exposure.ev100 = ev100;
    record.exposure.exposure = MID_GREY * 8.0 / exp2(ev100);
    record.exposure.luminance = exp2(log2_luminance);
    record.exposure.frames += 1u;
}
