// The surface a decal pass sees at a pixel, rebuilt from what the pipeline's earlier passes
// wrote. Position from depth (seed 001 Alg. 4.1); world-position derivatives for mip selection
// from the neighbouring depths on the same surface (depth.glsl), as the deferred lighting does.
//   - Deferred (default): the G-buffer's normal-mapped normal and receiver layers; the
//     geometric normal for the angle fade from depth.
//   - DECAL_SURFACE_VISIBILITY (forward and visibility buffer): the instance and triangle ids
//     of the visibility pass (the forward pipeline's prepass writes them when a decal pass
//     follows: 8 bytes a pixel and no texture fetch). The receiver layers come from the
//     instance and both normals are the interpolated vertex normal: the decal's normal frame is
//     built on it rather than on the normal-mapped one, which would mean sampling every
//     material's normal map twice. Where a decal covers a surface fully its normal replaces the
//     surface's anyway; where it covers part, the remaining weight keeps the surface's bumps.
#ifndef DECAL_SURFACE_GLSL
#define DECAL_SURFACE_GLSL

#include "scene.glsl"
#include "depth.glsl"
#include "decals.glsl"
#ifdef DECAL_SURFACE_VISIBILITY
#include "visibility.glsl"
#endif

// False for sky pixels (nothing to decal).
bool decal_surface_at(ivec2 px, out DecalSurface s) {
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) return false;
    s.position = world_from_depth(vec2(px), depth);
    world_derivatives(px, depth, s.position, s.dpdx, s.dpdy);
#ifdef DECAL_SURFACE_VISIBILITY
    VisibleSurface v = visible_surface(px, texelFetch(visibility_ids, px, 0).rg);
    s.geometric_normal = v.geometric_normal;
    s.normal = v.geometric_normal;
    s.layers = v.instance.decal_layers;
#else
    s.geometric_normal = safe_normalize(cross(s.dpdy, s.dpdx), vec3(0.0, 1.0, 0.0));
    s.normal = safe_normalize(texelFetch(gbuffer_normal, px, 0).xyz * 2.0 - 1.0, s.geometric_normal);
    if (dot(s.geometric_normal, s.normal) < 0.0) s.geometric_normal = -s.geometric_normal;
    s.layers = texelFetch(gbuffer_layers, px, 0).r;
#endif
    return true;
}

#endif
