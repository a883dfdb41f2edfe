#version 460
// Shadow pass, miss: nothing blocks the way to the light.
#extension GL_EXT_ray_tracing : require

layout(location = 0) rayPayloadInEXT uint unblocked;

void main() {
    unblocked = 1u;
}
