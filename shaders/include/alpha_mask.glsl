// The alpha test of a ray's candidate hit on a masked material (the scene TLAS marks masked
// instances non-opaque, so only they come here): interpolate the hit triangle's UVs at the
// barycentrics and compare the base colour's alpha (mip 0) with the cutoff, as the depth prepass
// does, so foliage and lattices cast the shadows of what is drawn.
#ifndef ALPHA_MASK_GLSL
#define ALPHA_MASK_GLSL

#include "scene.glsl"

bool alpha_mask_blocks(uint instance, uint primitive, vec2 bary) {
    GpuInstance inst = scene.instances.instances[instance];
    GpuMaterial m = scene.materials.materials[inst.material];
    if ((m.flags & MATERIAL_ALPHA_MASK) == 0u) return true;
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[inst.mesh];
    IndicesRef indices = IndicesRef(mesh.indices);
    VerticesRef vertices = VerticesRef(mesh.vertices);
    vec2 uv0 = vertices.vertices[indices.indices[primitive * 3u]].uv;
    vec2 uv1 = vertices.vertices[indices.indices[primitive * 3u + 1u]].uv;
    vec2 uv2 = vertices.vertices[indices.indices[primitive * 3u + 2u]].uv;
    vec2 uv = uv0 * (1.0 - bary.x - bary.y) + uv1 * bary.x + uv2 * bary.y;
    float alpha = m.base_color[3] * textureLod(textures[nonuniformEXT(m.base_color_tex)], uv, 0.0).a;
    return alpha >= m.alpha_cutoff;
}

#endif
