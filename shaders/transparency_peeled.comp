#version 460
// Depth-peeled transparency, composition (seed 002 §4.1.2: deferred shading with two G-buffers,
// the full-resolution reference the interlaced method is measured against). Both layers have
// been lit in full: first the nearest opaque surface (its lit image copied into
// `transparency_source`, its depth into `background_depth`), then the nearest surface of any
// kind, which the G-buffer and the HDR target now hold. Where that surface is glass
// (opacity < 1 in the G-buffer) its lit radiance T is rewritten as
//   C = α·T + (1 − α)·O
// with O the opaque layer's radiance at the refracted position (include/refraction.glsl, §3.3),
// or at the pixel itself when the opaque surface there lies in front of the glass or the
// position is off the image: the depth check. Every other pixel is already final.
#include "scene.glsl"
#include "refraction.glsl"
#include "storable.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(scene.camera.camera.viewport_size);
    if (any(greaterThanEqual(px, size))) return;
    float glass_depth = texelFetch(depth_target, px, 0).r;
    vec4 material = texelFetch(gbuffer_material, px, 0);
    float alpha = material.b;
    if (glass_depth <= 0.0 || alpha >= 1.0) return;
    vec3 n = texelFetch(gbuffer_normal, px, 0).xyz * 2.0 - 1.0;
    ivec2 q = px + refraction_offset(n, glass_depth, material.a);
    bool off_image = any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size));
    if (off_image || texelFetch(background_depth, q, 0).r >= glass_depth) q = px;
    vec3 background = texelFetch(transparency_source, q, 0).rgb;
    vec3 glass = imageLoad(hdr_image, px).rgb;
    imageStore(hdr_image, px, vec4(storable_radiance(alpha * glass + (1.0 - alpha) * background), 1.0));
}
