// variants: GBUFFER GBUFFER+RAY_QUERY_DECALS GBUFFER+DECAL_BUFFER RAY_QUERY_DECALS DECAL_BUFFER CLUSTERED_DECALS GLASS_LAYER
#version 460
// The reflection pass's rays on the ray-query tier (render/src/reflections): one invocation per
// cell (a pixel, or a 2×2 block at half resolution) runs reflections.glsl's reflection_cell,
// over the G-buffer's surfaces with GBUFFER, else the visibility ids', applying the primary
// surface's decals as the pipeline's shading does (the RAY_QUERY_DECALS, DECAL_BUFFER and
// CLUSTERED_DECALS variants). reflections_resolve.comp filters what the rays brought back and
// adds it to the HDR target.
#define REFLECTION_RAY_QUERY
#include "reflections.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    int side = (scene.lighting.lighting.reflection_flags & REFLECT_HALF_RES) != 0u ? 2 : 1;
    if (any(greaterThanEqual(cell * side, ivec2(scene.camera.camera.viewport_size)))) return;
    reflection_cell(cell);
}
