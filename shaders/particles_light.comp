#version 460
// Particle light (render/src/particles): one invocation per drawn particle, after light culling.
// Its light is what its emitter's `lit` share takes from the lights of the tile its centre
// falls in (a matte sprite facing each light), the ambient and the environment, written for
// the drawing to multiply its colour by: light per particle, not per pixel, so that the
// drawing's fragments do no more than coverage and blending (a fragment pass is where this
// work costs the most on the lent GPU).
#include "particles.glsl"
#include "light_tiles.glsl"
#include "lighting.glsl"
#include "environment.glsl"

layout(local_size_x = PARTICLE_GROUP) in;

layout(buffer_reference, std430, buffer_reference_align = 8) writeonly buffer ParticleLightRef { uvec2 light[]; };

// Irradiance / π at `p` from the lights of pixel `px`'s list (every light facing the sprite),
// the ambient and the environment.
vec3 particle_light(ivec2 px, vec3 p) {
    GpuCamera cam = scene.camera.camera;
    vec3 v = normalize(cam.position - p);
    vec3 total = cam.ambient + (environment_on() ? environment_irradiance(v) : vec3(0.0));
    if (scene.lighting.lighting.mode == LIGHTS_RAY_QUERY) return total; // no list to walk
    LightList list = light_list(px);
    for (uint j = 0u; j < list.count; ++j) {
        vec3 l;
        total += light_incidence(scene.lights.lights[light_slot(list, j)], p, l) * (1.0 / 3.14159265);
    }
    return total;
}

void main() {
    ParticleStateRef st = particle_state();
    uint i = gl_GlobalInvocationID.x;
    uint drawn = st.state.draw[1];
    // The drawing's indirect draw: PARTICLE_SPRITE_VERTICES a drawn particle, one instance.
    if (i == 0u) st.state.sprites = uint[4](PARTICLE_SPRITE_VERTICES * drawn, 1u, 0u, 0u);
    if (i >= drawn) return;
    uint slot = ParticleSlotsRef(st.state.alive_list).slots[i];
    GpuParticle p = ParticlesRef(st.state.pool).particles[slot];
    GpuEmitter e = particle_emitter(st, p.emitter);
    vec3 light = vec3(1.0);
    if (e.lit > 0.0) {
        GpuCamera cam = scene.camera.camera;
        vec4 clip = cam.view_proj * vec4(p.position, 1.0);
        vec2 ndc = clip.w > 0.0 ? clip.xy / clip.w : vec2(0.0);
        ivec2 px = clamp(ivec2(vec2(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * cam.viewport_size), ivec2(0), ivec2(cam.viewport_size) - 1);
        light = mix(vec3(1.0), particle_light(px, p.position), e.lit);
    }
    ParticleLightRef(st.state.light_list).light[i] = uvec2(packHalf2x16(light.rg), packHalf2x16(vec2(light.b, 0.0)));
}
