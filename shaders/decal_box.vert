#version 460
// Deferred decals (seed 000 §3.2): each decal's box is rasterised; instance i draws the i-th
// decal of the channel-then-weight order. Front faces are depth-tested against the scene
// (GREATER_OR_EQUAL, reverse-Z), so occluded boxes are rejected early. When the camera is inside
// a box (or within the near distance of it) its front faces are clipped away: that box is drawn
// inside-out instead (winding reversed, so its back faces pass the cull) and pinned to the near
// plane, so the depth test always passes and the box still covers its pixels. Draws of the
// particles' decal ring (DECAL_RING_DRAW) take instance i as the ring's place i.
#include "scene.glsl"
#include "decals.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer DecalOrderRef { uint slots[]; };
layout(location = 0) flat out uint v_slot;

// 12 triangles of the unit cube, counter-clockwise seen from outside; corner bits x, y, z.
const uint CUBE[36] = uint[36](
    0u, 2u, 1u, 1u, 2u, 3u,   4u, 5u, 6u, 5u, 7u, 6u,   // -z, +z
    0u, 1u, 4u, 1u, 5u, 4u,   2u, 6u, 3u, 3u, 6u, 7u,   // -y, +y
    0u, 4u, 2u, 2u, 4u, 6u,   1u, 3u, 5u, 3u, 7u, 5u);  // -x, +x

const float NEAR_MARGIN = 0.1; // world units; more than the camera's near distance

void main() {
    bool ring = (scene.texture_index & DECAL_RING_DRAW) != 0u;
    // A ring draw's instances are the ring's places, not the order table's entries: its load
    // stays at entry 0, in bounds.
    uint slot = DecalOrderRef(scene.decal_order).slots[ring ? 0u : uint(gl_InstanceIndex)];
    if (ring) {
        // The particles' decal ring (render/src/particles): place i, drawn by the draw of its
        // material's attribute set (a place whose decal has another, or none yet, collapses to
        // a point and draws nothing).
        slot = GPU_DECAL | uint(gl_InstanceIndex);
        GpuDecal r = decal_record(slot);
        uint flags = DecalMaterialsRef(scene.decal_materials).decal_materials[decal_material(r)].flags & 15u;
        if (r.receivers == 0u || flags != (scene.texture_index & 15u)) {
            gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
            v_slot = NO_DECAL;
            return;
        }
    }
    GpuDecal d = decal_record(slot);
    GpuCamera cam = scene.camera.camera;
    vec3 eye = (d.world_to_decal * vec4(cam.position, 1.0)).xyz;
    // The margin in decal units along each axis is NEAR_MARGIN × the length of that row of the
    // world-to-decal matrix (the gradient of the decal coordinate).
    mat3 rows = transpose(mat3(d.world_to_decal));
    vec3 margin = NEAR_MARGIN * vec3(length(rows[0]), length(rows[1]), length(rows[2]));
    bool inside = all(lessThanEqual(abs(eye), vec3(0.5) + margin));
    uint v = uint(gl_VertexIndex);
    uint k = inside ? v - v % 3u + (2u - v % 3u) : v; // reversed winding when inside
    uint corner = CUBE[k];
    vec3 local = vec3(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u) - 0.5;
    gl_Position = cam.motion_view_proj * (inverse(d.world_to_decal) * vec4(local, 1.0));
    if (inside) gl_Position.z = gl_Position.w; // depth 1: the near plane in reverse-Z
    v_slot = slot;
}
