// The decal buffer: what a decal pass (ray-tracing pipeline or ray-query compute) leaves for the
// shading passes, per pixel and attribute, as the collapsed composite of blend.glsl: the decal
// contribution and the weight remaining to the surface's own value, so that shading applies
// `value = decal + value × remaining` (seed 000 §4.3.1's final step). RGBA16F each; the count of
// decals tested per pixel goes beside them (for the debug views, and as the sign that the pixel
// has a composite at all), and the radiance emissive decals add (blend.glsl) in a fourth image.
#ifndef DECAL_BUFFER_GLSL
#define DECAL_BUFFER_GLSL

#include "scene.glsl"
#include "blend.glsl"

layout(set = 0, binding = BINDING_DECAL_ALBEDO, rgba16f) uniform image2D decal_albedo;
layout(set = 0, binding = BINDING_DECAL_NORMAL, rgba16f) uniform image2D decal_normal;
layout(set = 0, binding = BINDING_DECAL_SPEC, rgba16f) uniform image2D decal_spec;
layout(set = 0, binding = BINDING_DECAL_TESTED, r32ui) uniform uimage2D decal_tested;
layout(set = 0, binding = BINDING_DECAL_EMISSIVE, rgba16f) uniform image2D decal_emissive;

// A pixel where no decal was tested has the identity composite: only its count (0) is written,
// and decal_buffer_apply reads nothing more there. Where decals are sparse (most pixels of a
// game's frame), the pass writes 4 bytes a pixel instead of 36 and the shading reads 4.
void decal_buffer_store(ivec2 px, DecalBlend b, uint tested) {
    imageStore(decal_tested, px, uvec4(tested));
    if (tested == 0u) return;
    DecalComposite o = blend_collapse(b);
    imageStore(decal_albedo, px, o.albedo);
    imageStore(decal_normal, px, o.normal);
    imageStore(decal_spec, px, o.spec);
    imageStore(decal_emissive, px, vec4(o.emissive, 0.0));
}

// Applies the pixel's decals to the surface attributes; returns the decals tested there.
uint decal_buffer_apply(ivec2 px, inout vec3 albedo, inout vec3 n, inout float roughness, inout float metallic, inout vec3 emissive) {
    uint tested = imageLoad(decal_tested, px).r;
    if (tested == 0u) return 0u;
    DecalComposite o;
    o.albedo = imageLoad(decal_albedo, px);
    o.normal = imageLoad(decal_normal, px);
    o.spec = imageLoad(decal_spec, px);
    o.emissive = imageLoad(decal_emissive, px).rgb;
    blend_apply(o, albedo, n, roughness, metallic, emissive);
    return tested;
}

#endif
