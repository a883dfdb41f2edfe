#version 460
// Clustered decals, prefix sum (include/clusters.glsl): one workgroup turns the clusters' counts
// into list offsets, and writes the statistics of the lists (entries needed, the longest list,
// clusters used) into the buffer's header.
#include "scene.glsl"
#include "clusters.glsl"

const uint THREADS = 1024u;
layout(local_size_x = 1024) in;

shared uint partial[THREADS];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint n = cluster_count();
    uint per = (n + THREADS - 1u) / THREADS;
    uint first = t * per;
    ClusterWordsRef w = cluster_words();
    uint sum = 0u, longest = 0u, used = 0u;
    for (uint i = first; i < min(first + per, n); ++i) {
        uint c = w.words[counts_at() + i];
        sum += c;
        longest = max(longest, c);
        used += c > 0u ? 1u : 0u;
    }
    partial[t] = sum;
    barrier();
    // Inclusive Hillis–Steele scan of the per-thread sums.
    for (uint step = 1u; step < THREADS; step <<= 1) {
        uint v = t >= step ? partial[t - step] : 0u;
        barrier();
        partial[t] += v;
        barrier();
    }
    uint offset = partial[t] - sum;
    for (uint i = first; i < min(first + per, n); ++i) {
        w.words[offsets_at() + i] = offset;
        offset += w.words[counts_at() + i];
    }
    if (t == THREADS - 1u) w.words[STAT_ENTRIES] = partial[t];
    atomicMax(w.words[STAT_CLUSTER_MAX], longest);
    atomicAdd(w.words[STAT_CLUSTERS_USED], used);
}
