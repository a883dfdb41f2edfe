// variants: DECAL_SURFACE_VISIBILITY DECAL_SURFACE_DEPTH
#version 460
// The decal pass of clustered decals (no ray tracing at all): each pixel walks the decal list of
// its cluster (include/clusters.glsl) with the same test, texture sampling and per-channel
// weighted-OIT blending as the ray-traced passes (apply_decal in decals.glsl: the sums are
// order-independent within a channel, so list order does not matter), and writes the same
// decal buffer (forward and Forward+ walk the same lists inside their shading instead:
// shading.glsl, CLUSTERED_DECALS). It also sums, per workgroup then once into the cluster buffer's header, the
// decals tested and applied at each pixel, for the statistics.
#include "decal_surface.glsl"
#include "decal_buffer.glsl"
#include "clusters.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

shared uint group_tested, group_applied, group_pixels, group_tested_max, group_applied_max;

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        group_tested = 0u;
        group_applied = 0u;
        group_pixels = 0u;
        group_tested_max = 0u;
        group_applied_max = 0u;
    }
    barrier();
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    vec3 position;
    if (all(lessThan(px, ivec2(scene.camera.camera.viewport_size))) && decal_position_at(px, position)) {
        // The pixel's cluster first: where its list is empty (most pixels, where decals are
        // few), the rest of the surface (derivatives, normals, the instance) is never rebuilt.
        uvec2 list = cluster_list(uvec2(px), position);
        DecalBlend b;
        blend_init(b);
        uint applied = 0u, tested = 0u;
        DecalSurface s, skin;
        bool skinned;
        if (list.y > list.x && decal_surface_at(px, s, skinned, skin)) {
            applied = apply_cluster_list(b, list, s);
            tested = list.y - list.x;
            if (skinned) {   // the same list at the rest pose: decals on the skin are binned by their instance's bounds
                applied += apply_cluster_list(b, list, skin);
                tested *= 2u;
            }
        }
        decal_buffer_store(px, b, tested);
        atomicAdd(group_tested, tested);
        atomicAdd(group_applied, applied);
        atomicAdd(group_pixels, 1u);
        atomicMax(group_tested_max, tested);
        atomicMax(group_applied_max, applied);
    }
    barrier();
    // Every group adds its pixels; only groups that tested decals touch the other counters
    // (where decals are sparse, most groups: fewer atomics on the same few words).
    if (gl_LocalInvocationIndex == 0u && group_pixels > 0u) {
        atomicAdd(cluster_words().words[STAT_PIXELS], group_pixels);
        if (group_tested > 0u) {
            add64(STAT_TESTED_LO, group_tested);
            atomicMax(cluster_words().words[STAT_TESTED_MAX], group_tested_max);
        }
        if (group_applied > 0u) {
            add64(STAT_APPLIED_LO, group_applied);
            atomicMax(cluster_words().words[STAT_APPLIED_MAX], group_applied_max);
        }
    }
}
