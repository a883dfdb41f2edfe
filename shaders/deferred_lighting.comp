// variants: RAY_QUERY_DECALS DECAL_BUFFER RAY_QUERY_LIGHTS RAY_QUERY_LIGHTS+RAY_QUERY_DECALS RAY_QUERY_LIGHTS+DECAL_BUFFER
#version 460
// Deferred shading, lighting pass in compute (deferred_lighting.frag is the fragment version,
// deferred_lighting.rgen the ray-generation one for ray-query lights without ray queries): the
// same surface and shading, added to the emitted radiance in the HDR target through a storage
// image. Full-screen fragment passes are slow on some GPUs (docs/BENCHMARKS.md). The
// RAY_QUERY_LIGHTS variants find the lights with ray queries (ray_query_lights.glsl).
#ifdef RAY_QUERY_LIGHTS
#define ENUMERATED_LIGHTS
#else
#define TILE_SHARED_LIGHTS
#endif
// Before the includes: shading.glsl's staged lights are a workgroup's worth.
layout(local_size_x = 8, local_size_y = 8) in;
#include "deferred_surface.glsl"
#ifdef RAY_QUERY_LIGHTS
#include "ray_query_lights.glsl"
#endif

layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    bool inside = all(lessThan(px, ivec2(scene.camera.camera.viewport_size)));
    SurfaceInputs s;
    bool covered = inside && deferred_surface(px, s);
#ifdef TILE_SHARED_LIGHTS
    // A pipeline that stages its lights shades on every thread, surface or not: the whole
    // workgroup stages them (shading.glsl).
    vec4 shaded = covered || STAGED_LIGHTS ? shade_surface_in_group(s, px, covered) : vec4(0.0);
#else
    vec4 shaded = covered ? shade_surface(s, px) : vec4(0.0);
#endif
    if (!covered) return;
    vec4 emitted = imageLoad(hdr_image, px);
    imageStore(hdr_image, px, vec4(storable_radiance(emitted.rgb + shaded.rgb), emitted.a));
}
