// An inclusive prefix sum over a workgroup of SCAN_THREADS invocations (Hillis–Steele, in shared
// memory), for the passes that turn per-item counts into packed offsets with one atomic add per
// workgroup: the decal clusters' lists (decal_cluster_scan.comp) and the ray-tracing-pipeline
// decal pass's per-pixel lists (decal_list_offsets.comp). The includer defines SCAN_THREADS
// (its workgroup size); every invocation of the workgroup must call it.
#ifndef WORKGROUP_SCAN_GLSL
#define WORKGROUP_SCAN_GLSL

shared uint scan_partial[SCAN_THREADS];

// The sum of `value` over invocations 0..=t of the workgroup (t: gl_LocalInvocationIndex).
uint workgroup_inclusive_scan(uint value, uint t) {
    scan_partial[t] = value;
    barrier();
    for (uint step = 1u; step < SCAN_THREADS; step <<= 1) {
        uint v = t >= step ? scan_partial[t - step] : 0u;
        barrier();
        scan_partial[t] += v;
        barrier();
    }
    return scan_partial[t];
}

// The workgroup's total, after workgroup_inclusive_scan.
uint workgroup_scan_total() {
    return scan_partial[SCAN_THREADS - 1u];
}

#endif
