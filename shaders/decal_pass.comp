// variants: DECAL_SURFACE_VISIBILITY DECAL_SURFACE_DEPTH
#version 460
// The decal pass on the ray-query tier, in compute: the same decal buffer as the
// ray-tracing-pipeline pass (decal_pass.rgen), from the ray-query loop of decals.glsl, so the
// two formulations can be compared on one device and the shading passes have one way to
// consume decals.
#define RAY_QUERY_DECALS
#include "decal_surface.glsl"
#include "decal_buffer.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) return;
    DecalSurface s, skin;
    bool skinned;
    if (!decal_surface_at(px, s, skinned, skin)) return;
    DecalBlend b;
    blend_init(b);
    uint tested = gather_decals(b, s);
    if (skinned) tested += gather_decals(b, skin);
    decal_buffer_store(px, b, tested);
}
