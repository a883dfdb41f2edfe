// The surface a decal pass sees at a pixel, rebuilt from what the pipeline's earlier passes
// wrote. Position from depth (seed 001 Alg. 4.1); world-position derivatives for mip selection
// from the neighbouring depths on the same surface (depth.glsl), as the deferred lighting does.
//   - Deferred (default): the G-buffer's normal-mapped normal and receiver layers; the
//     geometric normal for the angle fade from depth.
//   - DECAL_SURFACE_VISIBILITY (forward and visibility buffer): the instance and triangle ids
//     of the visibility pass (the forward pipeline's prepass writes them when a decal must know
//     the instance or the ids are written anyway: 8 bytes a pixel and no texture fetch). The receiver layers come from the
//     instance and both normals are the interpolated vertex normal: the decal's normal frame is
//     built on it rather than on the normal-mapped one, which would mean sampling every
//     material's normal map twice. Where a decal covers a surface fully its normal replaces the
//     surface's anyway; where it covers part, the remaining weight keeps the surface's bumps.
//   - DECAL_SURFACE_DEPTH (forward and Forward+ where no instance has receiver layers of its
//     own and no decal is on a skin: SceneMirror::decals_need_instances): depth alone, so the
//     prepass writes no ids. Every pixel receives the default layers; both normals are the
//     geometric normal from depth (facing the camera), as the deferred pipeline's fade uses, so a
//     decal's normal map is built on the face rather than the interpolated normal. (Where both
//     neighbours on an axis lie on other surfaces, as on features one pixel wide, that normal
//     is a guess: the decals there may shade flat.)
// A posed mesh's pixel also gives its skin's view (decal_skin_view): its rest pose from the
// visibility ids, or in the deferred pipeline from the G-buffer's instance and triangle.
#ifndef DECAL_SURFACE_GLSL
#define DECAL_SURFACE_GLSL

#include "scene.glsl"
#include "depth.glsl"
#include "decals.glsl"
#include "visibility.glsl"

// The pixel's world position from depth alone; false for sky pixels. (What a pass needs to find
// a pixel's cluster before it rebuilds the rest of the surface.)
bool decal_position_at(ivec2 px, out vec3 position) {
    float depth = texelFetch(depth_target, px, 0).r;
    position = depth > 0.0 ? world_from_depth(vec2(px), depth) : vec3(0.0);
    return depth > 0.0;
}

// False for sky pixels (nothing to decal). `skinned`: the pixel is a posed mesh's, and `skin` is
// its skin's view.
bool decal_surface_at(ivec2 px, out DecalSurface s, out bool skinned, out DecalSurface skin) {
    float depth = texelFetch(depth_target, px, 0).r;
    skinned = false;
    if (depth <= 0.0) return false;
    vec3 position = world_from_depth(vec2(px), depth);
    vec3 dpdx, dpdy;
    world_derivatives(px, depth, position, dpdx, dpdy);
    vec3 rest_position, rest_normal;
#if defined(DECAL_SURFACE_DEPTH)
    vec3 geometric_normal = safe_normalize(cross(dpdy, dpdx), vec3(0.0, 1.0, 0.0));
    if (dot(geometric_normal, scene.camera.camera.position - position) < 0.0) geometric_normal = -geometric_normal;
    s = decal_world_view(position, dpdx, dpdy, geometric_normal, geometric_normal, DECAL_DEFAULT_LAYERS);
    return true;
#elif defined(DECAL_SURFACE_VISIBILITY)
    VisibleSurface v = visible_surface(px, texelFetch(visibility_ids, px, 0).rg);
    s = decal_world_view(position, dpdx, dpdy, v.geometric_normal, v.geometric_normal, v.instance.decal_layers);
    skinned = v.skinned;
    rest_position = v.rest_position;
    rest_normal = v.rest_normal;
#else
    vec3 geometric_normal = safe_normalize(cross(dpdy, dpdx), vec3(0.0, 1.0, 0.0));
    vec3 normal = safe_normalize(texelFetch(gbuffer_normal, px, 0).xyz * 2.0 - 1.0, geometric_normal);
    if (dot(geometric_normal, normal) < 0.0) geometric_normal = -geometric_normal;
    uvec2 ids = texelFetch(gbuffer_layers, px, 0).rg;
    s = decal_world_view(position, dpdx, dpdy, geometric_normal, normal, ids.x & 0xFFu);
    skinned = ids.y != 0u && rest_pose_of_pixel(px, ids.y - 1u, ids.x >> 8, geometric_normal, rest_position, rest_normal);
#endif
    if (skinned) skin = decal_skin_view(s, rest_position, rest_normal);
    return true;
}

#endif
