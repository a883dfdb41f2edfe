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
// Each command draws its instance at a level of detail (render/src/lod): the first phase picks
// it (with hysteresis), the second reads that choice, the glass and shadow views pick by their
// own projection.
#include "culling.glsl"

layout(local_size_x = 64) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer OrderRef { uint slots[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer ViewWordsRef { uint words[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ViewsRef { GpuShadowView views[]; };

layout(buffer_reference, std430, buffer_reference_align = 4) buffer LodsRef { uint levels[]; };

// Writes a command drawing `mesh` at level of detail `level` (0: the mesh itself) for instance
// `slot` (its firstInstance carries the level above the slot: render/src/lod). Returns the
// indices it draws.
uint write_command(GpuCullParams p, uint command, uint mesh, uint slot, uint instances, uint level) {
    GpuMeshInfo m = MeshesRef(p.meshes).meshes[mesh];
    CullWordsRef w = CullWordsRef(p.draws);
    uint o = p.commands + command * 5u;
    uint count = level > 0u ? m.lod_count[level - 1u] : m.index_count;
    w.words[o] = count;
    w.words[o + 1u] = instances;
    w.words[o + 2u] = level > 0u ? m.lod_first[level - 1u] : m.first_index;
    w.words[o + 3u] = m.vertex_offset;
    w.words[o + 4u] = slot | (level << LOD_LEVEL_SHIFT);
    return count;
}

void count(GpuCullParams p, uint word) {
    atomicAdd(CullWordsRef(p.draws).words[word], 1u);
}

// Counts a main-view draw: visible, at its level, its triangles.
void count_drawn(GpuCullParams p, uint level, uint indices) {
    count(p, CULL_STAT_VISIBLE);
    count(p, CULL_STAT_LOD + level);
    atomicAdd(CullWordsRef(p.draws).words[CULL_STAT_TRIANGLES], indices / 3u);
}

// Appends slot's command to `list` (0 or 1) of `batch`.
void emit(GpuCullParams p, uint list, uint batch, GpuCullRecord r, uint slot, uint level) {
    uint n = atomicAdd(CullWordsRef(p.draws).words[list * CULL_BATCHES + batch], 1u);
    if (n >= p.batch_capacity[batch]) {
        count(p, CULL_STAT_DROPPED);
        return;
    }
    count_drawn(p, level, write_command(p, list * p.list_stride + p.batch_start[batch] + n, r.mesh, slot, 1u, level));
}

// No finer than the finest level the instance's vertices hold: a posed mesh skinned for its
// coarser levels only this frame (render/src/skinning) names it in its record's flags.
uint drawable(GpuCullRecord r, uint level) {
    return max(level, (r.flags >> CULL_LEVEL_SHIFT) & CULL_LEVEL_MASK);
}

// The main view's level of detail for slot `slot` (inside the frustum): the coarsest level whose
// projected error stays within the limit; a coarser level than the one drawn last only when its
// error is within the tighter limit (hysteresis). Remembered for the second phase and the next
// frame.
uint choose_level(GpuCullParams p, GpuCullRecord r, uint slot) {
    if (p.lod_pixels <= 0.0) return 0u;
    GpuMeshInfo m = MeshesRef(p.meshes).meshes[r.mesh];
    if (m.lod_levels == 0u) return 0u;
    float scale = lod_pixels_per_error(p.view_proj, r.min, r.max, p.viewport.y);
    uint fits = lod_within(m, scale, p.lod_pixels);
    LodsRef lods = LodsRef(p.lods);
    uint kept = lods.levels[slot];
    uint level = drawable(r, fits < kept ? fits : max(kept, lod_within(m, scale, p.lod_coarsen_pixels)));
    if (level != kept) lods.levels[slot] = level;
    return level;
}

// The level the first phase chose for slot `slot` this frame.
uint chosen_level(GpuCullParams p, GpuCullRecord r, uint slot) {
    if (p.lod_pixels <= 0.0) return 0u;
    return drawable(r, min(LodsRef(p.lods).levels[slot], MeshesRef(p.meshes).meshes[r.mesh].lod_levels));
}

// A level without memory (glass, shadow views): the coarsest within the limit at `scale`.
uint level_at(GpuCullParams p, GpuCullRecord r, float scale) {
    if (p.lod_pixels <= 0.0) return 0u;
    return drawable(r, lod_within(MeshesRef(p.meshes).meshes[r.mesh], scale, p.lod_pixels));
}

// Shadow-map texels per unit of relative error for the box [lo, hi] in view `v` (its texel's
// world size at 1 m, or anywhere for an orthographic view), at the box's nearest depth.
float shadow_pixels_per_error(GpuShadowView v, vec3 lo, vec3 hi) {
    float w = 1.0;
    if (v.ortho == 0u) {
        vec4 r3 = matrix_row(v.view_proj, 3);
        w = dot(r3.xyz, (lo + hi) * 0.5) - dot(abs(r3.xyz), (hi - lo) * 0.5) + r3.w;
        if (w <= 1e-4) return 1e30;
    }
    return length(hi - lo) / max(v.texel * w, 1e-20);
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
        uint level = inside ? level_at(p, r, lod_pixels_per_error(p.view_proj, r.min, r.max, p.viewport.y)) : 0u;
        uint indices = write_command(p, p.ordered_first + i, r.mesh, slot, inside ? 1u : 0u, level);
        if (inside) {
            count(p, CULL_STAT_FRUSTUM);
            count_drawn(p, level, indices);
        }
        return;
    }
    if (i >= p.count) return;
    GpuCullRecord r = CullRecordsRef(p.records).records[i];
    if ((r.flags & CULL_LIVE) == 0u) return;
    if (pass == CULL_PASS_SHADOW_VIEWS) {
        uint v = gl_GlobalInvocationID.y;
        if (v >= p.shadow_count) return;
        uint offset = ViewWordsRef(p.shadow_views).words[0];
        GpuShadowView view = ViewsRef(p.shadow_views + uint64_t(offset) * 4ul).views[v];
        if (p.mode != CULL_MODE_OFF && !in_frustum(view.view_proj, r.min, r.max)) return;
        uint n = atomicAdd(CullWordsRef(p.draws).words[CULL_HEADER + v], 1u);
        if (n >= p.shadow_stride) {
            count(p, CULL_STAT_DROPPED);
            return;
        }
        uint level = level_at(p, r, shadow_pixels_per_error(view, r.min, r.max));
        write_command(p, p.shadow_first + v * p.shadow_stride + n, r.mesh, i, 1u, level);
        return;
    }
    if ((r.flags & CULL_TRANSPARENT) != 0u) return;
    uint batch = ((r.flags & CULL_MASKED) != 0u ? 2u : 0u) + ((r.flags & CULL_DOUBLE_SIDED) != 0u ? 1u : 0u);
    bool inside = p.mode == CULL_MODE_OFF || in_frustum(p.view_proj, r.min, r.max);
    if (pass == CULL_PASS_FIRST) {
        count(p, CULL_STAT_TESTED);
        if (!inside) return;
        count(p, CULL_STAT_FRUSTUM);
        uint level = choose_level(p, r, i);
        if (p.mode == CULL_MODE_OCCLUSION && !was_visible(p, i)) return;
        emit(p, 0u, batch, r, i, level);
        return;
    }
    // CULL_PASS_SECOND
    bool was = was_visible(p, i);
    bool visible = inside && !hiz_occluded(p.view_proj, r.min, r.max, p.hiz, uvec2(p.viewport), p.hiz_levels);
    if (visible != was) set_visible(p, i, visible);
    if (visible && !was) emit(p, 1u, batch, r, i, chosen_level(p, r, i));
}
