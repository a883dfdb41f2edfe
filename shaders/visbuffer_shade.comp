// variants: RAY_QUERY_DECALS DECAL_BUFFER RAY_QUERY_LIGHTS RAY_QUERY_LIGHTS+RAY_QUERY_DECALS RAY_QUERY_LIGHTS+DECAL_BUFFER
#version 460
// Visibility-buffer shading in compute (visbuffer_shade.frag is the fragment version,
// visbuffer_shade.rgen the ray-generation one for ray-query lights without ray queries): the
// same surface and shading, stored through a storage image into the HDR target; pixels no
// geometry covers get the clear colour. The RAY_QUERY_LIGHTS variants find the lights with ray
// queries (ray_query_lights.glsl).
#ifdef RAY_QUERY_LIGHTS
#define ENUMERATED_LIGHTS
#endif
#include "visbuffer_surface.glsl"
#ifdef RAY_QUERY_LIGHTS
#include "ray_query_lights.glsl"
#endif

layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform writeonly image2D hdr_image;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) return;
    SurfaceInputs s;
    if (!visbuffer_surface(px, s)) {
        imageStore(hdr_image, px, scene.lighting.lighting.clear_color);
        return;
    }
    imageStore(hdr_image, px, shade_surface(s, px));
}
