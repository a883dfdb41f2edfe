// Clustered decals (seed 000 §3.3.2.1: DOOM 2016's clustered shading, which the seed names as
// the comparison it did not make, §6): view clusters are screen tiles of DECAL_CLUSTER_TILE
// pixels × DECAL_CLUSTER_SLICES depth slices, exponential in view distance (render/src/decals/
// clustered.rs says how the sizes were chosen). Each frame compute
// passes bin every live decal's box into the clusters it touches (count, prefix sum, fill), and
// the decal pass walks the list of the pixel's cluster. One buffer holds it all (32-bit words):
//   [0, DECAL_CLUSTER_HEADER)   statistics (below), read back by the CPU
//   counts[C], offsets[C], cursors[C]   per cluster (C = tiles x × tiles y × slices)
//   entries[capacity]           decal record slots, cluster after cluster
// Entries past the capacity are dropped and counted (STAT_DROPPED); the renderer grows the buffer
// when it reads that back, two frames later.
#ifndef CLUSTERS_GLSL
#define CLUSTERS_GLSL

#include "scene.glsl"

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

// The depth slice of view distance `z` (metres in front of the camera).
uint cluster_slice(float z) {
    float near = float(DECAL_CLUSTER_NEAR_MM) * 1e-3;
    float s = log(max(z, near) / near) / log(float(DECAL_CLUSTER_FAR_M) / near) * float(DECAL_CLUSTER_SLICES);
    return uint(clamp(s, 0.0, float(DECAL_CLUSTER_SLICES - 1u)));
}

float view_distance(vec3 world) {
    return -(scene.camera.camera.view * vec4(world, 1.0)).z;
}

ClusterWordsRef cluster_words() {
    return ClusterWordsRef(scene.decal_clusters);
}

uint counts_at() { return DECAL_CLUSTER_HEADER; }
uint offsets_at() { return DECAL_CLUSTER_HEADER + cluster_count(); }
uint cursors_at() { return DECAL_CLUSTER_HEADER + 2u * cluster_count(); }
uint entries_at() { return DECAL_CLUSTER_HEADER + 3u * cluster_count(); }

// Adds `v` to the 64-bit counter at words[lo], words[lo + 1].
void add64(uint lo, uint v) {
    uint old = atomicAdd(cluster_words().words[lo], v);
    if (old + v < old) atomicAdd(cluster_words().words[lo + 1u], 1u);
}

#endif
