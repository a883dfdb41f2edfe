#version 460
// One box-filtered level of the environment's radiance cube (render/src/environment): each
// texel the bilinear mean of the four texels of the level above it (`scene.texture_index` is
// the level written). The prefiltering samples these levels by its samples' solid angles.
#include "environment_levels.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    GpuEnvironmentJob env = environment_job();
    uint level = scene.texture_index;
    uvec3 texel;
    vec3 d;
    if (!level_texel(max(env.face >> level, 1u), texel, d)) return;
    imageStore(environment_levels[level], ivec3(texel), vec4(textureLod(environment_source, d, float(level - 1u)).rgb, 1.0));
}
