#version 460
#extension GL_EXT_control_flow_attributes : require
// The environment's diffuse irradiance as nine spherical-harmonic coefficients (Ramamoorthi and
// Hanrahan 2001, "An Efficient Representation for Irradiance Environment Maps"): one workgroup
// projects the radiance cube's level of 32² texels a face (or its largest, if smaller), each
// texel weighted by its solid angle, reduces in shared memory, and stores the coefficients
// convolved with the cosine lobe and divided by π into the environment record, with the job's
// sun for the sky pass.
#include "environment_levels.glsl"

layout(buffer_reference, std430, buffer_reference_align = 16) buffer EnvironmentOut { GpuEnvironment environment; };
layout(local_size_x = 256) in;

shared vec3 partial[256];

void main() {
    GpuEnvironmentJob env = environment_job();
    uint level = 0u;
    while ((env.face >> level) > 32u && level + 1u < env.source_levels) ++level;
    uint size = max(env.face >> level, 1u);
    uint texels = 6u * size * size;
    vec3 c[9];
    for (int k = 0; k < 9; ++k) c[k] = vec3(0.0);
    for (uint i = gl_LocalInvocationIndex; i < texels; i += 256u) {
        uint face = i / (size * size);
        uvec2 px = uvec2(i % size, (i / size) % size);
        vec3 d = cube_direction(face, (vec2(px) + 0.5) / float(size));
        float w = cube_texel_solid_angle(px, size);
        vec3 radiance = textureLod(environment_source, d, float(level)).rgb * w;
        float y[9];
        sh9_basis(d, y);
        for (int k = 0; k < 9; ++k) c[k] += radiance * y[k];
    }
    // The cosine lobe's bands (π, 2π/3, π/4), over π: irradiance / π.
    const float band[3] = float[3](1.0, 2.0 / 3.0, 0.25);
    EnvironmentOut out_env = EnvironmentOut(scene.lighting.lighting.environment);
    // Loops kept loops: lavapipe splits a compute shader at each barrier, and the 90 barriers
    // of the unrolled reduction took its LLVM most of the pass's first frame to compile.
    [[dont_unroll]] for (int k = 0; k < 9; ++k) {
        partial[gl_LocalInvocationIndex] = c[k];
        barrier();
        [[dont_unroll]] for (uint stride = 128u; stride > 0u; stride >>= 1u) {
            if (gl_LocalInvocationIndex < stride) partial[gl_LocalInvocationIndex] += partial[gl_LocalInvocationIndex + stride];
            barrier();
        }
        if (gl_LocalInvocationIndex == 0u) out_env.environment.sh[k] = vec4(partial[0] * band[k == 0 ? 0 : (k < 4 ? 1 : 2)], 0.0);
        barrier();
    }
    if (gl_LocalInvocationIndex == 0u) {
        out_env.environment.sun = env.sun;
        out_env.environment.sun_color = env.sun_color;
    }
}
