// variants: SHADOWED_LIGHTS SAMPLED_LIGHTS
#version 460
// Ray-query lights, miss: the payload already holds every light found.
#extension GL_EXT_ray_tracing : require
#include "ray_pipeline_lights.glsl"

layout(location = 0) rayPayloadInEXT LightPayload payload;

void main() {
}
