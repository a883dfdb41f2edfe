#version 460
// Auto-exposure, pass 1 (render/src/exposure): every pixel of the HDR target into a histogram of
// log2 luminance, per workgroup in shared memory, then added to the record's.
#include "exposure.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

shared uint bins[EXPOSURE_BINS];

void main() {
    uint i = gl_LocalInvocationIndex;
    if (i < EXPOSURE_BINS) bins[i] = 0u;
    barrier();
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (all(lessThan(px, ivec2(scene.camera.camera.viewport_size)))) {
        atomicAdd(bins[exposure_bin(luminance(texelFetch(hdr_target, px, 0).rgb))], 1u);
    }
    barrier();
    if (i < EXPOSURE_BINS && bins[i] != 0u) atomicAdd(ExposureRef(scene.lighting.lighting.exposure).exposure.histogram[i], bins[i]);
}
