#version 460
// Debug view: the twelve edges of every live decal's oriented box (green) and of its AABB, the
// primitive the acceleration structure holds (yellow). One instance per live box (the box table
// is dense; each box names its decal record), 24 vertices (a line list).
#include "scene.glsl"
#include "decals.glsl"

layout(location = 0) out vec3 v_color;

// Edges of the unit cube as pairs of corner indices (bit 0 = x, bit 1 = y, bit 2 = z).
const uint EDGES[24] = uint[24](0u,1u, 2u,3u, 4u,5u, 6u,7u, 0u,2u, 1u,3u, 4u,6u, 5u,7u, 0u,4u, 1u,5u, 2u,6u, 3u,7u);

void main() {
    GpuAabb b = DecalBoxesRef(scene.decal_aabbs).boxes[gl_InstanceIndex];
    uint corner = EDGES[gl_VertexIndex % 24u];
    vec3 unit = vec3(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u);
    vec3 world;
    if (b.slot == NO_DECAL) {
        gl_Position = vec4(0.0);
        v_color = vec3(0.0);
        return;
    }
    if (scene.texture_index == 0u) {
        GpuDecal d = decal_record(b.slot);
        world = (inverse(d.world_to_decal) * vec4(unit - 0.5, 1.0)).xyz;
        v_color = vec3(0.1, 1.0, 0.2);
    } else {
        world = mix(vec3(b.min[0], b.min[1], b.min[2]), vec3(b.max[0], b.max[1], b.max[2]), unit);
        v_color = vec3(1.0, 0.85, 0.1);
    }
    gl_Position = scene.camera.camera.motion_view_proj * vec4(world, 1.0); // unjittered: drawn after TAA
}
