// variants: MOTION
#version 460
// Particles (render/src/particles): vertices PARTICLE_SPRITE_VERTICES·i onwards draw the i-th
// particle of the drawn list as a sprite facing the camera (one triangle; one instance of every
// sprite's vertices: the draw's count comes from particles_light.comp), its size and colour interpolated over its life, its sprite's cell
// of the emitter's flipbook chosen by age, its colour multiplied by the light
// particles_light.comp found for it. MOTION: the same quad for the motion vectors, also where
// it was a frame before (each point moved back by the particle's velocity over the frame's
// step, which is exactly the step's own motion: particles.glsl moves by the new velocity).
#include "particles.glsl"

layout(location = 0) out vec4 v_color;
layout(location = 1) out vec2 v_uv;
layout(location = 2) out float v_distance;
layout(location = 3) flat out uint v_texture;
layout(location = 4) flat out float v_softness;
// Where in the quad (0 to 1 across it; outside it beyond).
layout(location = 7) out vec2 v_local;

#ifdef MOTION
layout(location = 5) out vec4 v_now;
layout(location = 6) out vec4 v_before;
#endif

layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer ParticleLightRef { uvec2 light[]; };

// A sprite is one triangle (the drawing is bound by the triangles, not the fragments, on the lent
// GPU: docs/experiments/particles-gpu.md), in quad units (x right, y up; the quad spans ±0.5):
// around the untextured round dot, whose coverage is 0 beyond 0.5 from the centre, the
// equilateral triangle that holds that circle; around a textured sprite, the right triangle
// that holds the quad (the fragment shader drops what lies outside it).
const vec2 DOT[3] = vec2[3](vec2(0.0, 1.0), vec2(-0.8660254, -0.5), vec2(0.8660254, -0.5));
const vec2 QUAD[3] = vec2[3](vec2(-0.5, -0.5), vec2(1.5, -0.5), vec2(-0.5, 1.5));

void main() {
    ParticleStateRef st = particle_state();
    uint drawn = uint(gl_VertexIndex) / PARTICLE_SPRITE_VERTICES;
    uint slot = ParticleSlotsRef(st.state.alive_list).slots[drawn];
    GpuParticle p = ParticlesRef(st.state.pool).particles[slot];
    GpuEmitter e = particle_emitter(st, p.emitter);
    float t = particle_life(p);
    GpuCamera cam = scene.camera.camera;
    // The view matrix's rows are the camera's axes in the world.
    vec3 right = vec3(cam.view[0][0], cam.view[1][0], cam.view[2][0]);
    vec3 up = vec3(cam.view[0][1], cam.view[1][1], cam.view[2][1]);
    uint k = uint(gl_VertexIndex) % PARTICLE_SPRITE_VERTICES;
    vec2 corner = e.texture != TEXTURE_WHITE ? QUAD[k] : DOT[k];
    float size = mix(e.size_start, e.size_end, t);
    vec3 across = right * size, along = up * size;
    // A streak: the quad's long side along the motion on screen, as long as `stretch` seconds of it.
    vec3 moving = mat3(cam.view) * p.velocity;
    float on_screen = length(moving.xy);
    if (e.stretch > 0.0 && on_screen > 1e-4) {
        vec2 d = moving.xy / on_screen;
        across = (right * d.x + up * d.y) * (size + on_screen * e.stretch);
        along = (right * -d.y + up * d.x) * size;
    }
    vec3 world = p.position + across * corner.x + along * corner.y;
    gl_Position = cam.view_proj * vec4(world, 1.0);
    // The view distance along the camera's axis, for soft particles (the depth target's unit).
    v_distance = -(cam.view * vec4(world, 1.0)).z;
    // The light particles_light.comp found for it.
    uvec2 light = ParticleLightRef(st.state.light_list).light[drawn];
    v_color = mix(e.color_start, e.color_end, t) * vec4(unpackHalf2x16(light.x), unpackHalf2x16(light.y).x, 1.0);
    // Flipbook: frames left to right, top to bottom, through the particle's life.
    uvec2 cells = max(uvec2(e.flipbook & 0xFFFFu, e.flipbook >> 16u), uvec2(1u));
    uint frame = min(uint(t * float(cells.x * cells.y)), cells.x * cells.y - 1u);
    vec2 cell = vec2(frame % cells.x, frame / cells.x);
    v_local = vec2(corner.x + 0.5, 0.5 - corner.y);
    v_uv = (cell + v_local) / vec2(cells);
    v_texture = e.texture;
    v_softness = e.softness;
#ifdef MOTION
    vec3 before = world - p.velocity * st.state.delta;
    v_now = cam.motion_view_proj * vec4(world, 1.0);
    v_before = cam.prev_view_proj * vec4(before, 1.0);
#endif
}
