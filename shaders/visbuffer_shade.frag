// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Visibility-buffer deferred texturing, shading pass (seed 000 §5.1.3) as a full-screen fragment
// pass: each pixel rebuilds its surface from the ids, samples its material and shades it.
// visbuffer_shade.comp is the same in compute.
#define FRAGMENT_SHADER
#include "visbuffer_surface.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    SurfaceInputs s;
    if (!visbuffer_surface(px, s)) discard;
    out_color = shade_surface(s, px);
}
