// variants: MOTION
#version 460
// Particles (render/src/particles): the sprite's coverage (a soft round dot without a texture),
// faded where the opaque surface behind comes close (soft particles: the gap between the two
// view distances, the surface's from reverse-Z depth as near / depth), times the particle's
// lit colour (particles_light.comp lit it once, not per pixel), written premultiplied: alpha 0
// only adds light (sparks), alpha 1 covers (smoke, debris). MOTION: where the sprite covers more
// than half of a pixel, the particle's motion replaces the surface's behind it (so temporal
// anti-aliasing follows a spark instead of smearing it along the background's motion).
#include "scene.glsl"
#ifdef MOTION
#include "motion.glsl"
#endif

layout(location = 0) in vec4 v_color;
layout(location = 1) in vec2 v_uv;
layout(location = 2) in float v_distance;
layout(location = 3) flat in uint v_texture;
layout(location = 4) flat in float v_softness;
layout(location = 7) in vec2 v_local;
#ifdef MOTION
layout(location = 5) in vec4 v_now;
layout(location = 6) in vec4 v_before;
#endif
layout(location = 0) out vec4 out_color;

void main() {
    // The triangle around the sprite reaches past its quad (particle.vert): nothing there. The
    // untextured dot leaves at once (within the quad, its circle); a texture is sampled first
    // (its derivatives need every lane).
    float dot_edge = length(v_local - 0.5);
    if (v_texture == TEXTURE_WHITE && dot_edge >= 0.5) discard;
    bool inside = all(greaterThanEqual(v_local, vec2(0.0))) && all(lessThanEqual(v_local, vec2(1.0)));
    vec4 sprite = v_texture == TEXTURE_WHITE ? vec4(1.0, 1.0, 1.0, 1.0 - smoothstep(0.15, 0.5, dot_edge)) : sample_texture(v_texture, v_uv);
    float coverage = inside ? sprite.a : 0.0;
    if (v_softness > 0.0) {
        float depth = texelFetch(depth_target, ivec2(gl_FragCoord.xy), 0).r;
        // The projection is infinite reverse-Z: depth = near / view distance; its [3][2] is near.
        float behind = depth > 0.0 ? scene.camera.camera.proj[3][2] / depth : 1e30;
        coverage *= clamp((behind - v_distance) / v_softness, 0.0, 1.0);
    }
#ifdef MOTION
    if (coverage <= 0.5) discard;
    out_color = motion_record(v_now, v_before, abs(v_now.w), abs(v_before.w));
    return;
#endif
    if (coverage < 1.0 / 512.0) discard;
    // Premultiplied: the colour is added where the sprite covers, and hides as much of what is
    // behind as its opacity says (0: light added, nothing hidden).
    out_color = vec4(v_color.rgb * sprite.rgb * coverage, clamp(v_color.a, 0.0, 1.0) * coverage);
}
