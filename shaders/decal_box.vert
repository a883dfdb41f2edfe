#version 460
// Deferred decals (seed 000 §3.2): each decal's box is rasterised; instance i draws the i-th
// decal of the channel-then-weight order. Back faces only (front faces culled), so the box
// still covers its pixels when the camera is inside it.
#include "scene.glsl"
#include "decals.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer DecalOrderRef { uint slots[]; };
layout(location = 0) flat out uint v_slot;

// 12 triangles of the unit cube, counter-clockwise seen from outside; corner bits x, y, z.
const uint CUBE[36] = uint[36](
    0u, 2u, 1u, 1u, 2u, 3u,   4u, 5u, 6u, 5u, 7u, 6u,   // -z, +z
    0u, 1u, 4u, 1u, 5u, 4u,   2u, 6u, 3u, 3u, 6u, 7u,   // -y, +y
    0u, 4u, 2u, 2u, 4u, 6u,   1u, 3u, 5u, 3u, 7u, 5u);  // -x, +x

void main() {
    uint slot = DecalOrderRef(scene.decal_order).slots[gl_InstanceIndex];
    GpuDecal d = DecalsRef(scene.decals).decals[slot];
    uint corner = CUBE[gl_VertexIndex];
    vec3 local = vec3(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u) - 0.5;
    gl_Position = scene.camera.camera.view_proj * (inverse(d.world_to_decal) * vec4(local, 1.0));
    v_slot = slot;
}
