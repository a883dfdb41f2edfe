#version 460
// Clustered decals, tile depth bounds (include/clusters.glsl): the nearest and farthest view
// distance of the shaded pixels of each screen tile, one workgroup a tile, so that binning puts
// a decal only into the slices of the tile's range that its box reaches.
#include "scene.glsl"
#include "depth.glsl"
#include "clusters.glsl"

layout(local_size_x = 32, local_size_y = 8) in;

shared uint nearest, farthest;

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        nearest = 0x7F800000u;   // +inf: a tile with no shaded pixel bins nothing
        farthest = 0u;
    }
    barrier();
    uvec2 tile = gl_WorkGroupID.xy;
    uint lo = 0x7F800000u, hi = 0u;
    for (uint row = gl_LocalInvocationID.y; row < DECAL_CLUSTER_TILE; row += 8u) {
        for (uint column = gl_LocalInvocationID.x; column < DECAL_CLUSTER_TILE; column += 32u) {
            ivec2 px = ivec2(tile * DECAL_CLUSTER_TILE + uvec2(column, row));
            if (any(greaterThanEqual(px, ivec2(scene.camera.camera.viewport_size)))) continue;
            float depth = texelFetch(depth_target, px, 0).r;
            if (depth <= 0.0) continue;
            // The distance as the decal passes compute it (decal_position_at, then cluster_list;
            // binning's margin covers the rounding); positive floats order as their bits do.
            uint z = floatBitsToUint(view_distance(world_from_depth(vec2(px), depth)));
            lo = min(lo, z);
            hi = max(hi, z);
        }
    }
    atomicMin(nearest, lo);
    atomicMax(farthest, hi);
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        uint t = tile.y * cluster_tiles().x + tile.x;
        cluster_words().words[bounds_at() + 2u * t] = nearest;
        cluster_words().words[bounds_at() + 2u * t + 1u] = farthest;
    }
}
