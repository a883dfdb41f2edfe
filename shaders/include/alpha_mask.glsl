// What a shadow ray's candidate hit does to the light (the scene TLAS marks masked and blended
// instances non-opaque, so only they come here). Masked materials: interpolate the hit
// triangle's UVs at the barycentrics and compare the base colour's alpha (mip 0) with the
// cutoff, as the depth prepass does, so foliage and lattices cast the shadows of what is drawn.
// Blended materials (glass) with coloured shadows: the light carries on, filtered by the
// surface's colour × (1 − opacity) (seed 002 §3.2.1 eq. 3.1, the filter as a product so that
// several panes multiply); without coloured shadows glass blocks like an opaque surface.
#ifndef ALPHA_MASK_GLSL
#define ALPHA_MASK_GLSL

#include "scene.glsl"

vec4 hit_base_color(GpuInstance inst, GpuMaterial m, uint primitive, vec2 bary) {
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[inst.mesh];
    IndicesRef indices = IndicesRef(mesh.indices);
    VerticesRef vertices = VerticesRef(mesh.vertices);
    vec2 uv0 = unpack_uv(vertices.vertices[indices.indices[primitive * 3u]].uv, mesh);
    vec2 uv1 = unpack_uv(vertices.vertices[indices.indices[primitive * 3u + 1u]].uv, mesh);
    vec2 uv2 = unpack_uv(vertices.vertices[indices.indices[primitive * 3u + 2u]].uv, mesh);
    vec2 uv = uv0 * (1.0 - bary.x - bary.y) + uv1 * bary.x + uv2 * bary.y;
    vec4 base = vec4(m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3]);
    return base * textureLod(textures[nonuniformEXT(m.base_color_tex)], uv, 0.0);
}

// The fraction of each colour of light that passes the candidate hit: 0 blocks the ray, 1 lets
// it through untouched.
vec3 candidate_transmittance(uint instance, uint primitive, vec2 bary) {
    GpuInstance inst = scene.instances.instances[instance];
    GpuMaterial m = scene.materials.materials[inst.material];
    bool masked = (m.flags & MATERIAL_ALPHA_MASK) != 0u;
    bool blended = (m.flags & MATERIAL_BLEND) != 0u;
    if (blended && (scene.lighting.lighting.flags & COLOURED_SHADOWS) == 0u) return vec3(0.0);
    if (!masked && !blended) return vec3(0.0);
    vec4 c = hit_base_color(inst, m, primitive, bary);
    if (blended) return clamp(c.rgb * (1.0 - c.a), 0.0, 1.0);
    return c.a >= m.alpha_cutoff ? vec3(0.0) : vec3(1.0);
}

// Light below this (every channel) counts as blocked, so a ray ends at the pane that darkens
// it to nothing.
const float SHADOW_OPAQUE_BELOW = 1.0 / 256.0;

#endif
