#version 460
// The ray-tracing-pipeline decal pass's list allocation (include/decal_lists.glsl). Each run of
// DECAL_LIST_RUN pixels along a row shares one block of the entries, interleaved (entry i of the
// run's pixel j at i × DECAL_LIST_RUN + j), so that the lanes of a warp, which hold neighbouring
// pixels, write and read neighbouring words. The run's room is the most that any of its pixels
// asks for (decal_list_room of what it found last frame): a pixel at the edge of a decal, which
// found none last frame but finds some under a jittered or moving view, has its neighbours'
// room. Each workgroup of 256 pixels (32 runs) scans its runs' blocks in shared memory and
// reserves them with one atomic add, as the decal clusters' scan does (decal_cluster_scan.comp),
// and adds them to the need with another. A run whose block ends past the buffer's capacity gets
// none (NO_LIST), and those of its pixels that asked for room are counted; the renderer reads
// the need back and grows the buffer (render/src/decals/lists.rs).
#include "decal_lists.glsl"

#define SCAN_THREADS 256u
#include "workgroup_scan.glsl"

layout(local_size_x = 16, local_size_y = 16) in;

const uint RUNS = SCAN_THREADS / DECAL_LIST_RUN;
shared uint run_room[RUNS], run_start[RUNS];
shared uint base, denied;

void main() {
    uint t = gl_LocalInvocationIndex;
    uint run = t / DECAL_LIST_RUN, lane = t % DECAL_LIST_RUN;   // 16-wide rows: two runs a row
    if (t == 0u) denied = 0u;
    if (lane == 0u) run_room[run] = 0u;
    barrier();
    DecalListsRef l = decal_lists();
    uint p = decal_list_pixel(gl_GlobalInvocationID.xy);
    uint room = p != NO_LIST ? decal_list_room(l.words[decal_list_found_at() + p]) : 0u;
    if (room > 0u) atomicMax(run_room[run], room);
    barrier();
    uint block = lane == 0u ? run_room[run] * DECAL_LIST_RUN : 0u;
    uint end = workgroup_inclusive_scan(block, t);
    if (t == SCAN_THREADS - 1u && end > 0u) {
        // The need, for the statistics and the renderer's sizing, saturating; room is handed out
        // only while some is left, so the counter stays within a workgroup's blocks of the
        // capacity (at most 2³⁰ entries) and never wraps.
        uint needed = atomicAdd(l.words[LIST_NEEDED], end);
        if (needed + end < needed) atomicMax(l.words[LIST_NEEDED], 0xFFFFFFFFu);
        base = l.words[LIST_ALLOCATED] < scene.decal_list_capacity ? atomicAdd(l.words[LIST_ALLOCATED], end) : NO_LIST;
    }
    barrier();
    if (lane == 0u) {
        uint start = base + end - block;
        bool fits = block > 0u && base != NO_LIST && start + block <= scene.decal_list_capacity;
        run_start[run] = fits ? start : NO_LIST;
    }
    barrier();
    uint start = run_start[run];
    if (p != NO_LIST) {
        l.words[decal_list_start_at() + p] = start == NO_LIST ? NO_LIST : start + lane;
        l.words[decal_list_room_at() + p] = start == NO_LIST ? 0u : run_room[run];
    }
    if (start == NO_LIST && room > 0u) atomicAdd(denied, 1u);
    barrier();
    if (t == 0u && denied > 0u) atomicAdd(l.words[LIST_DENIED], denied);
}
