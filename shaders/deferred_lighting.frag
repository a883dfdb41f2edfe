// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Deferred shading, lighting pass (seed 000 §5.1.2) as a full-screen fragment pass: reads the
// G-buffer, applies decals to the attributes, lights them, and adds the result to the emitted
// radiance already in the HDR target. deferred_lighting.comp is the same in compute.
#define FRAGMENT_SHADER
#include "deferred_surface.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    SurfaceInputs s;
    if (!deferred_surface(px, s)) discard;
    out_color = shade_surface(s, px);
}
