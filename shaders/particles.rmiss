#version 460
// Particle collision rays (particles_simulate.rgen), miss: no contact (the payload's `hit`
// stays false).
#extension GL_EXT_ray_tracing : require

struct ParticleHit {
    bool hit;
    uvec2 ids;
    float t;
};
layout(location = 0) rayPayloadInEXT ParticleHit payload;

void main() {
}
