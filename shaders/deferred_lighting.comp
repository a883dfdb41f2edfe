// variants: RAY_QUERY_DECALS DECAL_BUFFER
#version 460
// Deferred shading, lighting pass in compute (deferred_lighting.frag is the fragment version):
// the same surface and shading, added to the emitted radiance in the HDR target through a
// storage image. Full-screen fragment passes are slow on some GPUs (docs/BENCHMARKS.md).
#include "deferred_surface.glsl"

layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) return;
    SurfaceInputs s;
    if (!deferred_surface(px, s)) return;
    vec4 emitted = imageLoad(hdr_image, px);
    imageStore(hdr_image, px, vec4(emitted.rgb + shade_surface(s, px).rgb, emitted.a));
}
