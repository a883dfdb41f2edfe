// The level-of-detail debug view (DEBUG_LOD; render/src/lod): each surface in the colour of the
// level its instance drew, found from the triangle's number, which counts level 0's triangles
// first and then each coarser level's (mesh_io.glsl's `v_triangle_base`).
#ifndef LOD_DEBUG_GLSL
#define LOD_DEBUG_GLSL

#include "scene.glsl"

// The level of detail of triangle `triangle` (counted from the mesh's first index) of the mesh
// instance `instance` draws: 0 for the mesh's own triangles, k + 1 for coarser level k's;
// NO_LEVELS for a mesh that has no coarser level.
const uint NO_LEVELS = 0xFFFFFFFFu;
uint lod_level_of(uint instance, uint triangle) {
    GpuMeshInfo m = MeshesRef(scene.meshes).meshes[scene.instances.instances[instance].mesh];
    if (m.lod_levels == 0u) return NO_LEVELS;
    uint index = m.first_index + triangle * 3u;
    uint level = 0u;
    for (uint k = 0u; k < m.lod_levels; k++) {
        if (index >= m.lod_first[k]) level = k + 1u;
    }
    return level;
}

// Level 0 white, then blue, green, yellow and red as the levels coarsen; meshes without levels
// dark grey.
vec3 lod_color(uint level) {
    if (level == NO_LEVELS) return vec3(0.1);
    const vec3 colors[5] = vec3[5](vec3(0.9), vec3(0.1, 0.3, 1.0), vec3(0.1, 0.9, 0.2), vec3(1.0, 0.85, 0.1), vec3(1.0, 0.15, 0.1));
    return colors[min(level, 4u)];
}

#endif
