#version 460
// Debug view: the twelve edges of every live decal's oriented box (green) and of its AABB, the
// primitive the acceleration structure holds (yellow). One instance per decal slot, 24 vertices
// (a line list); free slots collapse to nothing.
#include "scene.glsl"
#include "decals.glsl"

layout(location = 0) out vec3 v_color;

struct Aabb { float min_x, min_y, min_z, max_x, max_y, max_z; };
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer AabbsRef { Aabb aabbs[]; };

// Edges of the unit cube as pairs of corner indices (bit 0 = x, bit 1 = y, bit 2 = z).
const uint EDGES[24] = uint[24](0u,1u, 2u,3u, 4u,5u, 6u,7u, 0u,2u, 1u,3u, 4u,6u, 5u,7u, 0u,4u, 1u,5u, 2u,6u, 3u,7u);

void main() {
    GpuDecal d = DecalsRef(scene.decals).decals[gl_InstanceIndex];
    uint corner = EDGES[gl_VertexIndex % 24u];
    vec3 unit = vec3(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u);
    vec3 world;
    if (scene.texture_index == 0u) {
        world = (inverse(d.world_to_decal) * vec4(unit - 0.5, 1.0)).xyz;
        v_color = vec3(0.1, 1.0, 0.2);
    } else {
        Aabb b = AabbsRef(scene.decal_aabbs).aabbs[gl_InstanceIndex];
        world = mix(vec3(b.min_x, b.min_y, b.min_z), vec3(b.max_x, b.max_y, b.max_z), unit);
        v_color = vec3(1.0, 0.85, 0.1);
    }
    gl_Position = d.receivers == 0u ? vec4(0.0) : scene.camera.camera.view_proj * vec4(world, 1.0);
}
