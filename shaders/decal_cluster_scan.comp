#version 460
// Clustered decals, list allocation (include/clusters.glsl): turns the clusters' counts into
// list offsets and writes the statistics of the lists (entries needed, the longest list,
// clusters used) into the buffer's header. Each workgroup scans the counts of its 256 clusters
// in shared memory and reserves room for all of them with one atomic add on the entries
// counter, so the lists are packed back to back in whatever order the workgroups come (nothing
// reads them in cluster order). It replaced one workgroup scanning every cluster in turn:
// 0.07 ms at 1920x1080 on the lent H100, most of the binning once the boxes were bounded
// properly (docs/BENCHMARKS.md).
#include "scene.glsl"
#include "clusters.glsl"

#define SCAN_THREADS 256u
#include "workgroup_scan.glsl"

layout(local_size_x = 256) in;

shared uint base, longest, used;

void main() {
    uint t = gl_LocalInvocationID.x;
    uint c = gl_GlobalInvocationID.x;
    ClusterWordsRef w = cluster_words();
    uint count = c < cluster_count() ? w.words[counts_at() + c] : 0u;
    if (t == 0u) {
        longest = 0u;
        used = 0u;
    }
    barrier();
    if (count > 0u) {
        atomicMax(longest, count);
        atomicAdd(used, 1u);
    }
    uint end = workgroup_inclusive_scan(count, t);
    if (t == SCAN_THREADS - 1u && end > 0u) {
        base = atomicAdd(w.words[STAT_ENTRIES], end);
        atomicMax(w.words[STAT_CLUSTER_MAX], longest);
        atomicAdd(w.words[STAT_CLUSTERS_USED], used);
    }
    barrier();
    if (count > 0u) w.words[offsets_at() + c] = base + end - count;
}
