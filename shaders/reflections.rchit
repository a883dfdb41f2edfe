#version 460
// Reflection rays, closest hit (reflections.glsl): what the ray hit.
#extension GL_EXT_ray_tracing : require
#define REFLECTION_HIT_SHADERS
#include "reflections.glsl"

layout(location = 0) rayPayloadInEXT ReflectionHits payload;
hitAttributeEXT vec2 bary;

void main() {
    payload.hit = true;
    payload.ids = uvec2(gl_InstanceCustomIndexEXT, gl_PrimitiveID);
    payload.bary = bary;
    payload.t = gl_HitTEXT;
}
