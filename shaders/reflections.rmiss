#version 460
// Reflection rays, miss: nothing hit (the payload's `hit` stays false; the sky is shaded in the
// ray-generation shader).
#extension GL_EXT_ray_tracing : require
#define REFLECTION_HIT_SHADERS
#include "reflections.glsl"

layout(location = 0) rayPayloadInEXT ReflectionHits payload;

void main() {
}
