// variants: GBUFFER GBUFFER+RAY_QUERY_DECALS GBUFFER+DECAL_BUFFER RAY_QUERY_DECALS DECAL_BUFFER CLUSTERED_DECALS
#version 460
// The reflection pass's rays in screen space (render/src/reflections), where there is no ray
// tracing or when asked for: reflections.glsl's reflection_cell, each ray marched through the
// depth buffer and seeing this frame's lit image (REFLECTION_SCREEN_SPACE), over the G-buffer's
// surfaces with GBUFFER, else the visibility ids', the primary surface's decals applied as the
// pipeline's shading does. reflections_resolve.comp filters and adds the result as for traced
// rays.
#define REFLECTION_SCREEN_SPACE
#include "reflections.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    int side = (scene.lighting.lighting.reflection_flags & REFLECT_HALF_RES) != 0u ? 2 : 1;
    if (any(greaterThanEqual(cell * side, ivec2(scene.camera.camera.viewport_size)))) return;
    reflection_cell(cell);
}
