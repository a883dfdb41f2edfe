#version 460
// GPU culling (render/src/culling): one invocation per instance slot (or blended order entry,
// or slot and shadow view), writing compacted VkDrawIndexedIndirectCommands per batch.
//   CULL_PASS_FIRST: frustum (mode ≥ frustum); with occlusion only what was drawn last frame
//     (its visibility bit): the first list.
//   CULL_PASS_SECOND: after the first list's depth and its pyramid: every instance in the
//     frustum is tested against the pyramid, its bit updated, and the newly visible ones go
//     into the second list, drawn in the same frame.
//   CULL_PASS_ORDERED: the blended instances in back-to-front order, one command each, its
//     instance count 0 when culled, so the order holds.
//   CULL_PASS_SHADOW_VIEWS: every live instance against each shadow-map view's frustum.
#include "culling.glsl"

layout(local_size_x = 64) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer OrderRef { uint slots[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer ViewWordsRef { uint words[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ViewsRef { GpuShadowView views[]; };

void write_command(GpuCullParams p, uint command, uint mesh, uint slot, uint instances) {
    GpuMeshInfo m = MeshesRef(p.meshes).meshes[mesh];
    CullWordsRef w = CullWordsRef(p.draws);
    uint o = p.commands + command * 5u;
    w.words[o] = m.index_count;
    w.words[o + 1u] = instances;
    w.words[o + 2u] = m.first_index;
    w.words[o + 3u] = m.vertex_offset;
    w.words[o + 4u] = slot;
}

void count(GpuCullParams p, uint word) {
    atomicAdd(CullWordsRef(p.draws).words[word], 1u);
}

// Appends slot's command to `list` (0 or 1) of `batch`.
void emit(GpuCullParams p, uint list, uint batch, GpuCullRecord r, uint slot) {
    uint n = atomicAdd(CullWordsRef(p.draws).words[list * CULL_BATCHES + batch], 1u);
    if (n >= p.batch_capacity[batch]) {
        count(p, CULL_STAT_DROPPED);
        return;
    }
    write_command(p, list * p.list_stride + p.batch_start[batch] + n, r.mesh, slot, 1u);
    count(p, CULL_STAT_VISIBLE);
}

bool was_visible(GpuCullParams p, uint slot) {
    return (CullWordsRef(p.visibility).words[slot >> 5u] & (1u << (slot & 31u))) != 0u;
}

void set_visible(GpuCullParams p, uint slot, bool visible) {
    uint bit = 1u << (slot & 31u);
    if (visible) atomicOr(CullWordsRef(p.visibility).words[slot >> 5u], bit);
    else atomicAnd(CullWordsRef(p.visibility).words[slot >> 5u], ~bit);
}

void main() {
    GpuCullParams p = cull_params();
    uint i = gl_GlobalInvocationID.x;
    uint pass = cull.pass;
    if (pass == CULL_PASS_ORDERED) {
        if (i == 0u) CullWordsRef(p.draws).words[CULL_ORDERED] = p.ordered_count;
        if (i >= p.ordered_count) return;
        uint slot = OrderRef(p.order).slots[i];
        GpuCullRecord r = CullRecordsRef(p.records).records[slot];
        bool inside = p.mode == CULL_MODE_OFF || in_frustum(p.view_proj, r.min, r.max);
        count(p, CULL_STAT_TESTED);
        if (inside) {
            count(p, CULL_STAT_FRUSTUM);
            count(p, CULL_STAT_VISIBLE);
        }
        write_command(p, p.ordered_first + i, r.mesh, slot, inside ? 1u : 0u);
        return;
    }
    if (i >= p.count) return;
    GpuCullRecord r = CullRecordsRef(p.records).records[i];
    if ((r.flags & CULL_LIVE) == 0u) return;
    if (pass == CULL_PASS_SHADOW_VIEWS) {
        uint v = gl_GlobalInvocationID.y;
        if (v >= p.shadow_count) return;
        uint offset = ViewWordsRef(p.shadow_views).words[0];
        mat4 view_proj = ViewsRef(p.shadow_views + uint64_t(offset) * 4ul).views[v].view_proj;
        if (p.mode != CULL_MODE_OFF && !in_frustum(view_proj, r.min, r.max)) return;
        uint n = atomicAdd(CullWordsRef(p.draws).words[CULL_HEADER + v], 1u);
        if (n >= p.shadow_stride) {
            count(p, CULL_STAT_DROPPED);
            return;
        }
        write_command(p, p.shadow_first + v * p.shadow_stride + n, r.mesh, i, 1u);
        return;
    }
    if ((r.flags & CULL_TRANSPARENT) != 0u) return;
    uint batch = ((r.flags & CULL_MASKED) != 0u ? 2u : 0u) + ((r.flags & CULL_DOUBLE_SIDED) != 0u ? 1u : 0u);
    bool inside = p.mode == CULL_MODE_OFF || in_frustum(p.view_proj, r.min, r.max);
    if (pass == CULL_PASS_FIRST) {
        count(p, CULL_STAT_TESTED);
        if (!inside) return;
        count(p, CULL_STAT_FRUSTUM);
        if (p.mode == CULL_MODE_OCCLUSION && !was_visible(p, i)) return;
        emit(p, 0u, batch, r, i);
        return;
    }
    // CULL_PASS_SECOND
    bool was = was_visible(p, i);
    bool visible = inside && !hiz_occluded(p.view_proj, r.min, r.max, p.hiz, uvec2(p.viewport), p.hiz_levels);
    if (visible != was) set_visible(p, i, visible);
    if (visible && !was) emit(p, 1u, batch, r, i);
}
