// variants: ALPHA_MASK GLASS GLASS+INTERLACED_ROWS
#version 460
// Deferred shading, geometry pass (seed 000 §2.6): material attributes into the G-buffer.
//   albedo    RGBA8_SRGB      albedo, occlusion      (sRGB keeps dark albedo precise in 8 bits)
//   normal    A2B10G10R10     shading normal × 0.5 + 0.5 (10 bits a component, and linear, so
//                             deferred decals can alpha-blend into it; an octahedral encoding
//                             would be tighter but cannot be blended)
//   material  RGBA8_UNORM     roughness, metallic, opacity (1 for opaque surfaces and the
//                             sky), refraction (over 0..REFRACTION_MAX_MM millimetres)
//   layers    RG32_UINT       decal receiver layers in the low 8 bits of x (the deferred
//                             pipelines support 8 layers), the triangle above them; y: the
//                             instance slot + 1 of a posed mesh (0 for others), whose rest pose
//                             decals on its skin are found at (visibility.glsl,
//                             rest_pose_of_pixel)
//   hdr       RGBA16F         emitted radiance (the lighting pass adds to it)
// The geometric normal that decals fade by is reconstructed from depth, so it costs no storage.
// GLASS: blended surfaces, drawn after the opaque ones with the same depth test and writes, with
// their opacity and refraction: the nearest surface of any kind wins each pixel (depth peeling's
// second G-buffer, seed 002 §4.1.2; transparency_peeled.comp blends it after lighting).
// GLASS+INTERLACED_ROWS: the same on odd rows only (seed 002 §2.4.2, §3.1); even rows keep the
// opaque surface behind, and the composition pass (transparency_compose.comp) blends the
// nearest blended surface of an odd row over the even rows' opaque samples after lighting.
#include "scene.glsl"
#include "mesh_io.glsl"
#include "material.glsl"
#include "lod_debug.glsl"

layout(location = 0) out vec4 gb_albedo;
layout(location = 1) out vec4 gb_normal;
layout(location = 2) out vec4 gb_material;
layout(location = 3) out uvec2 gb_layers;
layout(location = 4) out vec4 out_emissive;

void main() {
    GpuMaterial m = scene.materials.materials[v_material];
    MaterialSample ms = sample_material(m, v_uv, dFdx(v_uv), dFdy(v_uv));
#ifdef ALPHA_MASK
    if (ms.base.a < m.alpha_cutoff) discard;
#endif
#ifdef GLASS
#ifdef INTERLACED_ROWS
    if ((int(gl_FragCoord.y) & 1) == 0) discard;
#endif
    float opacity = clamp(ms.base.a, 0.0, 1.0);
    float refraction = clamp(m.refraction / (float(REFRACTION_MAX_MM) * 1e-3), 0.0, 1.0);
#else
    float opacity = 1.0;
    float refraction = 0.0;
#endif
    vec3 geometric_n = safe_normalize(v_normal, vec3(0.0, 1.0, 0.0));
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !gl_FrontFacing) geometric_n = -geometric_n;
    vec3 n = perturb_normal(geometric_n, v_tangent, ms.tangent_normal, m.normal_scale);
    gb_albedo = vec4(ms.base.rgb, ms.occlusion);
    if (scene.debug_view == DEBUG_LOD) gb_albedo.rgb = lod_color(lod_level_of(v_instance, uint(gl_PrimitiveID) + v_triangle_base));
    gb_normal = vec4(n * 0.5 + 0.5, 1.0);
    gb_material = vec4(ms.roughness, ms.metallic, opacity, refraction);
    gb_layers = uvec2((scene.instances.instances[v_instance].decal_layers & 0xFFu) | ((uint(gl_PrimitiveID) + v_triangle_base) << 8), v_skinned ? v_instance + 1u : 0u);
    out_emissive = vec4(scene.debug_view == DEBUG_LIT ? ms.emissive : vec3(0.0), 1.0);
}
