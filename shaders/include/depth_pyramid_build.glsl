// Building a depth pyramid (depth_pyramid.glsl) HIZ_LEVELS_PER_DISPATCH levels a dispatch: each
// 8×8 workgroup writes its 8×8 texels of the first level, then from shared memory the 4×4, 2×2
// and 1×1 texels above them. A block of texels covers exactly the block above it, clamping at
// the edges included (texel i covers 2i and 2i + 1 of the level below, the last one clamped), so
// no workgroup needs another's texels until the next dispatch. The pyramid ends at its first
// 1×1 level (or at HIZ_MAX_LEVELS), as render/src/culling's `hiz_levels` counts them. For
// compute shaders with local_size 8×8 only (it declares shared memory).
#ifndef DEPTH_PYRAMID_BUILD_GLSL
#define DEPTH_PYRAMID_BUILD_GLSL

#include "depth_pyramid.glsl"

shared float pyramid_block[64];

// Writes levels `first` .. `first + HIZ_LEVELS_PER_DISPATCH - 1` of pyramid `h` (those the
// pyramid has) over this workgroup's block: the nearest of the texels below when `nearest`,
// else the farthest. Every invocation must call it (it waits at barriers).
void pyramid_levels(HizRef h, uvec2 viewport, uint first, bool nearest) {
    uvec2 local = gl_LocalInvocationID.xy;
    uvec2 group = gl_WorkGroupID.xy;
    uint span = 8u;
    for (uint k = 0u; k < HIZ_LEVELS_PER_DISPATCH; k++) {
        uint level = first + k;
        uvec2 size = hiz_size(viewport, level);
        uvec2 t = group * span + local;
        bool inside = all(lessThan(local, uvec2(span))) && all(lessThan(t, size));
        float d = 0.0;
        if (inside) {
            if (k == 0u) {
                d = pyramid_texel(h, viewport, level, t, nearest);
            } else {
                // The level below, from this block's texels of it (2·span on a side).
                uvec2 below = hiz_size(viewport, level - 1u);
                uvec2 origin = group * (2u * span);
                uvec2 a = min(2u * t, below - 1u) - origin, b = min(2u * t + 1u, below - 1u) - origin;
                uint w = 2u * span;
                vec4 c = vec4(pyramid_block[a.y * w + a.x], pyramid_block[a.y * w + b.x], pyramid_block[b.y * w + a.x],
                              pyramid_block[b.y * w + b.x]);
                d = pyramid_reduce(c, nearest);
            }
            h.depth[hiz_offset(viewport, level) + t.y * size.x + t.x] = d;
        }
        // The same for every invocation: the loop ends uniformly (and the last level of the
        // dispatch is not kept in shared memory: the next dispatch reads it from `h`).
        if (all(equal(size, uvec2(1u))) || level + 1u >= HIZ_MAX_LEVELS || k + 1u == HIZ_LEVELS_PER_DISPATCH) break;
        barrier(); // every invocation has read the block below
        if (inside) pyramid_block[local.y * span + local.x] = d;
        barrier(); // the block is written
        span /= 2u;
    }
}

#endif
