#version 460
// One triangle that covers the screen; uv (0,0) at the top-left.
layout(location = 0) out vec2 v_uv;

void main() {
    vec2 uv = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    v_uv = uv;
    // The viewport is flipped (pipeline.rs), so clip +Y is up: uv.y = 0 is the top row.
    gl_Position = vec4(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
}
