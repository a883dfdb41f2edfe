#version 460
// Particle collision rays (particles_simulate.rgen), closest hit: the triangle and the distance.
#extension GL_EXT_ray_tracing : require

struct ParticleHit {
    bool hit;
    uvec2 ids;
    float t;
};
layout(location = 0) rayPayloadInEXT ParticleHit payload;

void main() {
    payload.hit = true;
    payload.ids = uvec2(gl_InstanceCustomIndexEXT, gl_PrimitiveID);
    payload.t = gl_HitTEXT;
}
