// variants: FILL WIDE FILL+WIDE
#version 460
// Clustered decals, binning (include/clusters.glsl): BIN_LANES threads per live decal box. The
// box's eight corners, seen from the camera, give the screen tiles it may touch and its view
// distances (boxes wholly behind the camera or off screen touch none); the lanes share those
// tiles out, and each tile's depth bounds give the box's slices there.
// Without FILL the pass counts the decals of each cluster; with FILL (after the lists' allocation) it
// writes their record slots. One thread per box left a big box's hundreds of clusters to one
// thread: filling the lists of 100 puddles took 0.98 ms on an H200, 8 lanes a box 0.13 ms.
// A decal on a skin has its box in its instance's rest pose, which the camera never sees: it is
// binned by the instance's posed bounds (its culling record) instead, wherever the skin is now.
#include "scene.glsl"
#include "decals.glsl"
#include "clusters.glsl"

const uint BIN_LANES = 8u;
// How far a box's view distances are widened before they meet a tile's. The corners' distances
// (from the view-projection) and a pixel's (from its world position) round differently, which
// 0.01 % covers for a decal pass, whose pixels' positions come from the depth target as the
// tiles' bounds do. WIDE, for a forward shading pass that walks the lists itself: under MSAA its
// fragments take their own positions, up to 1 % off the depth of the sample that the depth
// target keeps (msaa.glsl's surface pixel allows 1 % of the fragment's depth: 1/0.99 of it).
#ifdef WIDE
const float DEPTH_MARGIN = 0.0102;
#else
const float DEPTH_MARGIN = 1e-4;
#endif
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer OwnerBoundsRef { GpuCullRecord records[]; };
layout(local_size_x = 64) in;

// Grows the view-distance range and the pixel rectangle by clip-space point `c` (in front of the
// near plane).
void bound_point(vec4 c, vec2 viewport, inout float zmin, inout float zmax, inout vec2 smin, inout vec2 smax) {
    zmin = min(zmin, c.w);
    zmax = max(zmax, c.w);
    // Pixels, row 0 at NDC y = +1 (the viewport is flipped).
    vec2 ndc = c.xy / c.w;
    vec2 px = vec2(ndc.x + 1.0, 1.0 - ndc.y) * 0.5 * viewport;
    smin = min(smin, px);
    smax = max(smax, px);
}

void main() {
    // Workgroups run in rows of DECAL_BIN_ROW (dispatches are limited to 65,535 a dimension).
    uint group = gl_WorkGroupID.y * DECAL_BIN_ROW + gl_WorkGroupID.x;
    uint box = group * (64u / BIN_LANES) + gl_LocalInvocationID.x / BIN_LANES;
    uint lane = gl_LocalInvocationID.x % BIN_LANES;
    if (box >= scene.decal_count) return;
    // The scene's boxes, then those of the particles' decal ring (render/src/particles), which
    // `decal_count` counts in when there is one.
    GpuLighting l = scene.lighting.lighting;
    uint scene_boxes = scene.decal_count - l.decal_ring_room;
    GpuAabb b;
    if (box < scene_boxes) {
        b = DecalBoxesRef(scene.decal_aabbs).boxes[box];
    } else {
        ParticleDecalBoxesRef ring = ParticleDecalBoxesRef(l.decal_ring_boxes);
        uint place = ring_place(box - scene_boxes);
        b.min = ring.boxes[place].min;
        b.max = ring.boxes[place].max;
        b.slot = ring.boxes[place].slot;
        b.owner = 0u;
    }
    if (b.slot == NO_DECAL) return;
    GpuCamera cam = scene.camera.camera;
    vec3 lo = vec3(b.min[0], b.min[1], b.min[2]);
    vec3 hi = vec3(b.max[0], b.max[1], b.max[2]);
    if (b.owner != 0u) {
        GpuCullRecord owner = OwnerBoundsRef(scene.lighting.lighting.culls).records[b.owner - 1u];
        lo = owner.min;
        hi = owner.max;
    }
    // A box of a decal whose transform is not finite lands nowhere (as the acceleration
    // structures treat a NaN box as inactive); its garbage extent must not become a loop bound.
    if (any(isnan(lo)) || any(isnan(hi)) || any(isinf(lo)) || any(isinf(hi))) return;
    // The part of the box in front of the camera's near plane: its corners there, and where its
    // twelve edges cross the plane. Its projection bounds the tiles, its view distances the
    // slices. (Taking the whole screen for a box that reaches behind the camera, as this pass
    // once did, sent every decal at the viewer's feet to thousands of clusters: 0.5 ms of
    // binning at 1,000 decals in PEERS.md's scene on the lent H100.)
    float near = max(cam.proj[3][2], 1e-4);   // reverse-Z, infinite far: clip.z = near, clip.w = view distance
    float zmin = 1e30, zmax = -1e30;
    vec2 smin = vec2(1e30), smax = vec2(-1e30);
    for (uint i = 0u; i < 8u; ++i) {
        vec4 ci = cam.view_proj * vec4(mix(lo, hi, vec3(i & 1u, (i >> 1) & 1u, (i >> 2) & 1u)), 1.0);
        if (ci.w >= near) bound_point(ci, cam.viewport_size, zmin, zmax, smin, smax);
        for (uint axis = 0u; axis < 3u; ++axis) {
            // Each edge once, from its corner with the axis's bit clear.
            uint j = i | (1u << axis);
            if (j == i) continue;
            vec4 cj = cam.view_proj * vec4(mix(lo, hi, vec3(j & 1u, (j >> 1) & 1u, (j >> 2) & 1u)), 1.0);
            if ((ci.w >= near) == (cj.w >= near)) continue;
            vec4 c = mix(ci, cj, (near - ci.w) / (cj.w - ci.w));
            bound_point(vec4(c.xyz, near), cam.viewport_size, zmin, zmax, smin, smax);
        }
    }
    if (zmax < near) return;   // wholly behind the near plane
    if (any(greaterThanEqual(smin, cam.viewport_size)) || any(lessThan(smax, vec2(0.0)))) return;   // off screen
    uvec2 tiles = cluster_tiles();
    uvec2 t0 = uvec2(clamp(smin, vec2(0.0), cam.viewport_size - 1.0)) / DECAL_CLUSTER_TILE;
    uvec2 t1 = min(uvec2(clamp(smax, vec2(0.0), cam.viewport_size - 1.0)) / DECAL_CLUSTER_TILE, tiles - 1u);
    // Each tile the box's rectangle covers: the part of the box's distances that the tile's
    // shaded pixels reach (decal_cluster_bounds.comp), in that tile's slices. A box in front of or
    // behind everything the tile shows lands in none of its clusters.
    // Rounding also grows with the coordinates' size: a world far from its origin widens more.
    float slack = 1e-5 * length(cam.position);
    uvec2 extent = t1 - t0 + 1u;
    uint n = extent.x * extent.y;
    ClusterWordsRef w = cluster_words();
    for (uint i = lane; i < n; i += BIN_LANES) {
        uvec2 tile = t0 + uvec2(i % extent.x, i / extent.x);
        vec2 range = tile_depth(tile.y * tiles.x + tile.x);
        float lo = max(zmin * (1.0 - DEPTH_MARGIN) - slack, range.x), hi = min(zmax * (1.0 + DEPTH_MARGIN) + slack, range.y);
        if (lo > hi) continue;
        uint last = tile_slice(range, hi);
        for (uint slice = tile_slice(range, lo); slice <= last; ++slice) {
            uint c = cluster_index(tile, slice);
#ifdef FILL
            // Within the count of the cluster's list, whatever this compilation's rounding: an
            // entry the counting pass did not see is dropped, not written into the next list.
            uint k = atomicAdd(w.words[cursors_at() + c], 1u);
            uint at = w.words[offsets_at() + c] + k;
            if (k < w.words[counts_at() + c] && at < scene.decal_list_capacity) {
                w.words[entries_at() + at] = b.slot;
            } else {
                atomicAdd(w.words[STAT_DROPPED], 1u);
            }
#else
            atomicAdd(w.words[counts_at() + c], 1u);
#endif
        }
    }
}
