#version 460
// One level of the depth pyramid (render/src/culling): each texel the farthest (smallest,
// reverse Z) of the 2×2 texels below it, clamped at the edges; level 0 reads the depth target.
#include "culling.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    GpuCullParams p = cull_params();
    uvec2 viewport = uvec2(p.viewport);
    uint level = cull.level;
    uvec2 size = hiz_size(viewport, level);
    uvec2 t = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(t, size))) return;
    HizRef h = HizRef(p.hiz);
    float d;
    if (level == 0u) {
        ivec2 m = ivec2(viewport) - 1;
        ivec2 a = min(ivec2(2u * t), m), b = min(ivec2(2u * t + 1u), m);
        d = min(min(texelFetch(depth_target, a, 0).r, texelFetch(depth_target, ivec2(b.x, a.y), 0).r),
                min(texelFetch(depth_target, ivec2(a.x, b.y), 0).r, texelFetch(depth_target, b, 0).r));
    } else {
        uvec2 below = hiz_size(viewport, level - 1u);
        uint o = hiz_offset(viewport, level - 1u);
        uvec2 a = min(2u * t, below - 1u), b = min(2u * t + 1u, below - 1u);
        d = min(min(h.depth[o + a.y * below.x + a.x], h.depth[o + a.y * below.x + b.x]),
                min(h.depth[o + b.y * below.x + a.x], h.depth[o + b.y * below.x + b.x]));
    }
    h.depth[hiz_offset(viewport, level) + t.y * size.x + t.x] = d;
}
