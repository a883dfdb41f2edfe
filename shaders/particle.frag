#version 460
// Particles (render/src/particles): the sprite's coverage (a soft round dot without a texture)
// times the particle's opacity, faded where the opaque surface behind comes close (soft
// particles), its colour lit as much as the emitter says by its tile's lights, the ambient and
// the environment (a matte sprite facing each light), written premultiplied: alpha 0 only adds
// light (sparks), alpha 1 covers (smoke, debris).
#include "particles.glsl"
#include "depth.glsl"
#include "light_tiles.glsl"
#include "lighting.glsl"
#include "environment.glsl"

layout(location = 0) in vec4 v_color;
layout(location = 1) in vec2 v_uv;
layout(location = 2) in vec3 v_world;
layout(location = 3) flat in uint v_texture;
layout(location = 4) flat in vec2 v_soft_lit;
layout(location = 0) out vec4 out_color;

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
    vec4 sprite = v_texture == TEXTURE_WHITE
        ? vec4(1.0, 1.0, 1.0, 1.0 - smoothstep(0.15, 0.5, length(v_uv - 0.5)))
        : sample_texture(v_texture, v_uv);
    float coverage = sprite.a;
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(depth_target, px, 0).r;
    float softness = v_soft_lit.x;
    if (softness > 0.0 && depth > 0.0) {
        vec3 eye = scene.camera.camera.position;
        float gap = distance(eye, world_from_depth(vec2(px), depth)) - distance(eye, v_world);
        coverage *= clamp(gap / softness, 0.0, 1.0);
    }
    vec3 color = v_color.rgb * sprite.rgb;
    float lit = v_soft_lit.y;
    vec3 radiance = lit > 0.0 ? color * mix(vec3(1.0), particle_light(px, v_world), lit) : color;
    // Premultiplied: the colour is added where the sprite covers, and hides as much of what is
    // behind as its opacity says (0: light added, nothing hidden).
    out_color = vec4(radiance * coverage, clamp(v_color.a, 0.0, 1.0) * coverage);
}
