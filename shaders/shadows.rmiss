#version 460
// Shadow pass, miss: nothing blocks the way to the light (w = 1); rgb holds what the glass it
// crossed let through.
#extension GL_EXT_ray_tracing : require

layout(location = 0) rayPayloadInEXT vec4 shadow_payload;

void main() {
    shadow_payload.w = 1.0;
}
