// Clustered decals (seed 000 §3.3.2.1: DOOM 2016's clustered shading, which the seed names as
// the comparison it did not make, §6): view clusters are screen tiles of DECAL_CLUSTER_TILE
// pixels × DECAL_CLUSTER_SLICES depth slices. The slices of a tile cut the view distances its
// shaded pixels reach (measured from the depth target each frame), exponentially, so that no
// list holds decals in front of or behind everything the tile shows (render/src/decals/
// clustered.rs says how the sizes were chosen and what the bounds gained). Each frame compute
// passes bound the tiles, bin every live decal's box into the clusters it touches (count,
// allocate, fill), and the decal pass walks the list of the pixel's cluster. One buffer holds it
// all (32-bit words):
//   [0, DECAL_CLUSTER_HEADER)   statistics (below), read back by the CPU
//   counts[C], offsets[C], cursors[C]   per cluster (C = tiles x × tiles y × slices)
//   bounds[2T]                  per tile (T = tiles x × tiles y): nearest and farthest distance
//   entries[capacity]           decal record slots, cluster after cluster
// Entries past the capacity are dropped and counted (STAT_DROPPED); the renderer grows the buffer
// when it reads that back, two frames later.
#ifndef CLUSTERS_GLSL
#define CLUSTERS_GLSL

#include "scene.glsl"
#include "decals.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) buffer ClusterWordsRef { uint words[]; };

const uint STAT_ENTRIES = 0u;        // entries the clusters needed (the sum of the counts)
const uint STAT_DROPPED = 1u;        // entries that did not fit
const uint STAT_CLUSTER_MAX = 2u;    // most decals in one cluster
const uint STAT_CLUSTERS_USED = 3u;  // clusters holding any decal
const uint STAT_TESTED_LO = 4u;      // decals tested, summed over shaded pixels (64-bit)
const uint STAT_TESTED_HI = 5u;
const uint STAT_TESTED_MAX = 6u;     // most decals tested at one pixel
const uint STAT_PIXELS = 7u;         // shaded pixels
const uint STAT_APPLIED_LO = 8u;     // decals applied (box holds the pixel, layers match), summed (64-bit)
const uint STAT_APPLIED_HI = 9u;
const uint STAT_APPLIED_MAX = 10u;   // most decals applied at one pixel

// Screen tiles across and down (the render targets' size over DECAL_CLUSTER_TILE, rounded up).
uvec2 cluster_tiles() {
    return uvec2(scene.decal_cluster_tiles & 0xFFFFu, scene.decal_cluster_tiles >> 16);
}

uint cluster_count() {
    uvec2 t = cluster_tiles();
    return t.x * t.y * DECAL_CLUSTER_SLICES;
}

uint cluster_index(uvec2 tile, uint slice) {
    uvec2 t = cluster_tiles();
    return (slice * t.y + tile.y) * t.x + tile.x;
}

float view_distance(vec3 world) {
    return -(scene.camera.camera.view * vec4(world, 1.0)).z;
}

ClusterWordsRef cluster_words() {
    return ClusterWordsRef(scene.decal_lists);
}

uint counts_at() { return DECAL_CLUSTER_HEADER; }
uint offsets_at() { return DECAL_CLUSTER_HEADER + cluster_count(); }
uint cursors_at() { return DECAL_CLUSTER_HEADER + 2u * cluster_count(); }
uint bounds_at() { return DECAL_CLUSTER_HEADER + 3u * cluster_count(); }
uint entries_at() { uvec2 t = cluster_tiles(); return bounds_at() + 2u * t.x * t.y; }

// The view distances tile `tile` (its index) shows: x nearest, y farthest (x > y: no shaded
// pixel, and no decal in any of its clusters).
vec2 tile_depth(uint tile) {
    ClusterWordsRef w = cluster_words();
    return vec2(uintBitsToFloat(w.words[bounds_at() + 2u * tile]), uintBitsToFloat(w.words[bounds_at() + 2u * tile + 1u]));
}

// The depth slice of view distance `z` within a tile's range `range`: exponential in distance
// from its nearest, the range cut into DECAL_CLUSTER_SLICES but no slice thinner than 2 % of its
// distance (a tile of one flat surface facing the camera is one slice).
uint tile_slice(vec2 range, float z) {
    float thickness = max(log(range.y / range.x) / float(DECAL_CLUSTER_SLICES), 0.0198);   // log(1.02)
    return uint(clamp(log(z / range.x) / thickness, 0.0, float(DECAL_CLUSTER_SLICES - 1u)));
}

// The decal list of the cluster that holds world point `position`, seen at pixel `px`: entries
// [first, end) of cluster_words() (cut at the capacity when the lists overflowed).
uvec2 cluster_list(uvec2 px, vec3 position) {
    uvec2 tile = px / DECAL_CLUSTER_TILE;
    vec2 range = tile_depth(tile.y * cluster_tiles().x + tile.x);
    if (range.x > range.y) return uvec2(0u);   // a tile the depth target shows nothing in
    // A point a little off the tile's range (a forward fragment is interpolated where the depth
    // target was not sampled) takes the nearest slice; binning's margin keeps its decals there.
    uint c = cluster_index(tile, tile_slice(range, clamp(view_distance(position), range.x, range.y)));
    ClusterWordsRef w = cluster_words();
    uint first = w.words[offsets_at() + c];
    return uvec2(first, min(first + w.words[counts_at() + c], scene.decal_list_capacity));
}

// The blending channels of the decals of `list` that land on surface `s` (their receivers
// match and their boxes hold the point), a bit each: the box test alone, without the blend
// state, so that a pixel no decal covers (most of them) skips blending altogether.
uint landing_channels(uvec2 list, DecalSurface s) {
    ClusterWordsRef w = cluster_words();
    uint channels = 0u;
    for (uint i = list.x; i < list.y; ++i) {
        uint index = w.words[entries_at() + i];
        if (index == NO_DECAL) continue;
        GpuDecal d = decal_record(index);
        vec3 local;
        float fade;
        if (decal_receives(d, s.layers) && decal_locate(d, s.position, s.geometric_normal, local, fade)) channels |= 1u << decal_channel(d);
    }
    return channels;
}

// Blends the decals of `list` in `channel` that land on surface `s` (for DECAL_BLEND_ONE_CHANNEL).
void apply_cluster_channel(inout DecalBlend b, uvec2 list, DecalSurface s, uint channel) {
    ClusterWordsRef w = cluster_words();
    for (uint i = list.x; i < list.y; ++i) {
        uint index = w.words[entries_at() + i];
        if (index == NO_DECAL) continue;
        GpuDecal d = decal_record(index);
        if (decal_channel(d) == channel) apply_decal_record(b, d, s);
    }
}

// Tests every decal of `list` against surface `s` and blends those that apply (apply_decal:
// the per-channel weighted blending is order-independent within a channel, so the list's order,
// whatever the binning's atomics gave, does not matter). Returns how many applied.
uint apply_cluster_list(inout DecalBlend b, uvec2 list, DecalSurface s) {
    ClusterWordsRef w = cluster_words();
    uint applied = 0u;
    for (uint i = list.x; i < list.y; ++i) {
        applied += apply_decal(b, w.words[entries_at() + i], s) ? 1u : 0u;
    }
    return applied;
}

// Adds `v` to the 64-bit counter at words[lo], words[lo + 1].
void add64(uint lo, uint v) {
    uint old = atomicAdd(cluster_words().words[lo], v);
    if (old + v < old) atomicAdd(cluster_words().words[lo + 1u], 1u);
}

#endif
