// Depth pyramids in one buffer, level after level: GPU culling's (render/src/culling: each texel
// the farthest of the texels below it) and screen-space reflections' (render/src/reflections:
// the nearest). Level 0 is half the viewport (rounded up), each level half the one before:
// texel i of a level covers texels 2i and 2i + 1 of the level below (the last one clamped), so
// every pixel is covered.
#ifndef DEPTH_PYRAMID_GLSL
#define DEPTH_PYRAMID_GLSL

#include "scene.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) buffer HizRef { float depth[]; };

// Size of level `level` for a `viewport` of pixels.
uvec2 hiz_size(uvec2 viewport, uint level) {
    uint shift = level + 1u;
    uint round = (1u << shift) - 1u;
    return max(uvec2(1u), (viewport + uvec2(round)) >> shift);
}

// Word offset of level `level` in the pyramid.
uint hiz_offset(uvec2 viewport, uint level) {
    uint offset = 0u;
    for (uint l = 0u; l < level; l++) {
        uvec2 s = hiz_size(viewport, l);
        offset += s.x * s.y;
    }
    return offset;
}

// One texel from the 2×2 below it: the nearest (reverse Z: the largest) when `nearest`, else the
// farthest.
float pyramid_reduce(vec4 d, bool nearest) {
    return nearest ? max(max(d.x, d.y), max(d.z, d.w)) : min(min(d.x, d.y), min(d.z, d.w));
}

// Texel `t` of level `level` of pyramid `h`, from the level below (or the depth target for level
// 0): the nearest of its 2×2 texels when `nearest`, else the farthest (reverse Z: the largest or
// the smallest).
float pyramid_texel(HizRef h, uvec2 viewport, uint level, uvec2 t, bool nearest) {
    vec4 d;
    if (level == 0u) {
        ivec2 m = ivec2(viewport) - 1;
        ivec2 a = min(ivec2(2u * t), m), b = min(ivec2(2u * t + 1u), m);
        d = vec4(texelFetch(depth_target, a, 0).r, texelFetch(depth_target, ivec2(b.x, a.y), 0).r, texelFetch(depth_target, ivec2(a.x, b.y), 0).r,
                 texelFetch(depth_target, b, 0).r);
    } else {
        uvec2 below = hiz_size(viewport, level - 1u);
        uint o = hiz_offset(viewport, level - 1u);
        uvec2 a = min(2u * t, below - 1u), b = min(2u * t + 1u, below - 1u);
        d = vec4(h.depth[o + a.y * below.x + a.x], h.depth[o + a.y * below.x + b.x], h.depth[o + b.y * below.x + a.x], h.depth[o + b.y * below.x + b.x]);
    }
    return pyramid_reduce(d, nearest);
}

#endif
