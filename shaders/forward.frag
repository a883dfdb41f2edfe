// variants: RAY_QUERY_DECALS DECAL_BUFFER CLUSTERED_DECALS MSAA MSAA+RAY_QUERY_DECALS MSAA+DECAL_BUFFER MSAA+CLUSTERED_DECALS MSAA+REFLECTED MSAA+REFLECTED+RAY_QUERY_DECALS MSAA+REFLECTED+DECAL_BUFFER MSAA+REFLECTED+CLUSTERED_DECALS TRANSPARENT TRANSPARENT+RAY_QUERY_DECALS TRANSPARENT+SHADOWED_GLASS TRANSPARENT+SHADOWED_GLASS+RAY_QUERY_DECALS
#version 460
// Forward shading pass (depth test EQUAL against the prepass): the material through the
// bindless array, normal mapping, then shade_surface (decals: ray queries, the decal buffer, or
// the clustered decals' lists walked in place; then every light).
// TRANSPARENT variants shade blended surfaces in the transparency pass (depth test GREATER,
// no depth write, back to front; crate::transparency): the same shading with the material's
// opacity as alpha, blended over what is behind (glTF's "over" operator); the opaque surface's
// decal buffer is not theirs, so only in-shader ray-query decals apply; the nearest blended
// surface at a pixel reads the shadow pass's glass layer in the SHADOWED_GLASS variants (frames
// with GLASS_SHADOWS), glass behind it is lit unshadowed.
// MSAA variants run once per pixel and primitive over multisampled attachments; the per-pixel
// inputs (shadows, occlusion, decal buffer, light tile) are read at the pixel of the fragment's
// own surface (msaa.glsl); the REFLECTED ones add the reflections' term resolved before them the
// same way (the reflection resolve's SEPARATE variant), so each sample reflects what its surface
// does.
#define FRAGMENT_SHADER
#include "scene.glsl"
#include "mesh_io.glsl"
#include "material.glsl"
#include "shading.glsl"
#include "lod_debug.glsl"
#ifdef MSAA
#include "msaa.glsl"
#endif
#ifdef REFLECTED
layout(set = 0, binding = BINDING_REFLECTION_ADDED, rgba16f) uniform readonly image2D reflection_added;
#endif

layout(location = 0) out vec4 out_color;

void main() {
    GpuMaterial m = scene.materials.materials[v_material];
    // Derivatives first, in uniform control flow: the decal loop cannot take them (§4.1.3).
    vec3 dpdx = dFdx(v_world_pos);
    vec3 dpdy = dFdy(v_world_pos);
    MaterialSample ms = sample_material(m, v_uv, dFdx(v_uv), dFdy(v_uv));

    vec3 geometric_n = safe_normalize(v_normal, vec3(0.0, 1.0, 0.0));
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !gl_FrontFacing) geometric_n = -geometric_n;

    SurfaceInputs s;
    s.position = v_world_pos;
    s.dpdx = dpdx;
    s.dpdy = dpdy;
    s.geometric_normal = geometric_n;
    s.normal = perturb_normal(geometric_n, v_tangent, ms.tangent_normal, m.normal_scale);
    s.albedo = ms.base.rgb;
    if (scene.debug_view == DEBUG_LOD) s.albedo = lod_color(lod_level_of(v_instance, uint(gl_PrimitiveID) + v_triangle_base));
    s.roughness = ms.roughness;
    s.metallic = ms.metallic;
    s.occlusion = ms.occlusion;
    s.emissive = ms.emissive;
    s.decal_layers = scene.instances.instances[v_instance].decal_layers;
    s.skinned = v_skinned;
    s.rest_position = v_rest_pos;
    s.rest_normal = safe_normalize(v_rest_normal, geometric_n);
    if (dot(v_normal, geometric_n) < 0.0) s.rest_normal = -s.rest_normal;
#ifdef MSAA
    ivec2 surface_px = msaa_surface_pixel(ivec2(gl_FragCoord.xy), gl_FragCoord.z);
    out_color = shade_surface(s, surface_px);
#ifdef REFLECTED
    out_color.rgb = storable_radiance(max(out_color.rgb + imageLoad(reflection_added, surface_px).rgb, vec3(0.0)));
#endif
#else
    out_color = shade_surface(s, ivec2(gl_FragCoord.xy));
#endif
#ifdef TRANSPARENT
    out_color.a = clamp(ms.base.a, 0.0, 1.0);
#endif
}
