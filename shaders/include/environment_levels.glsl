// What the environment's filtering passes share (render/src/environment): the record they read,
// the cube levels they write as storage images, and the radiance cube they sample.
#ifndef ENVIRONMENT_LEVELS_GLSL
#define ENVIRONMENT_LEVELS_GLSL

#include "environment.glsl"
#include "cubemap.glsl"
#include "normals.glsl"

layout(set = 0, binding = BINDING_ENVIRONMENT_LEVELS, rgba16f) uniform writeonly image2DArray environment_levels[ENVIRONMENT_LEVEL_VIEWS];
layout(set = 0, binding = BINDING_ENVIRONMENT_SOURCE) uniform samplerCube environment_source;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer EnvironmentJobRef { GpuEnvironmentJob job; };

GpuEnvironmentJob environment_job() {
    return EnvironmentJobRef(scene.lighting.lighting.environment_job).job;
}

// The texel this invocation writes of a level `size` texels wide (z: the face), and its
// direction; false past the level's edge.
bool level_texel(uint size, out uvec3 texel, out vec3 dir) {
    texel = gl_GlobalInvocationID;
    if (any(greaterThanEqual(texel.xy, uvec2(size)))) return false;
    dir = cube_direction(texel.z, (vec2(texel.xy) + 0.5) / float(size));
    return true;
}

#endif
