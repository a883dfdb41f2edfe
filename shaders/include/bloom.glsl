// The bloom pyramid (render/src/bloom): `bloom_levels` levels in one buffer, level 0 at half the
// viewport's resolution and each next at half the one above, RGB as half floats in two words a
// texel (alpha unused), rows one after another and levels one after another.
#ifndef BLOOM_GLSL
#define BLOOM_GLSL

#include "scene.glsl"

layout(buffer_reference, std430, buffer_reference_align = 8) buffer BloomRef { uvec2 texels[]; };

uvec2 bloom_size(uint level) {
    uvec2 viewport = uvec2(scene.camera.camera.viewport_size);
    return max(viewport >> (level + 1u), uvec2(1u));
}

uint bloom_offset(uint level) {
    uint offset = 0u;
    for (uint i = 0u; i < level; ++i) {
        uvec2 s = bloom_size(i);
        offset += s.x * s.y;
    }
    return offset;
}

vec3 bloom_load(uint level, ivec2 p) {
    uvec2 size = bloom_size(level);
    uvec2 q = uvec2(clamp(p, ivec2(0), ivec2(size) - 1));
    uvec2 t = BloomRef(scene.lighting.lighting.bloom).texels[bloom_offset(level) + q.y * size.x + q.x];
    return vec3(unpackHalf2x16(t.x), unpackHalf2x16(t.y).x);
}

void bloom_store(uint level, uvec2 p, vec3 c) {
    uvec2 size = bloom_size(level);
    BloomRef(scene.lighting.lighting.bloom).texels[bloom_offset(level) + p.y * size.x + p.x] = uvec2(packHalf2x16(c.rg), packHalf2x16(vec2(c.b, 0.0)));
}

// Bilinear filtering of a level at `uv` (0–1 across it), edges clamped.
vec3 bloom_sample(uint level, vec2 uv) {
    vec2 p = uv * vec2(bloom_size(level)) - 0.5;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - vec2(i);
    return mix(mix(bloom_load(level, i), bloom_load(level, i + ivec2(1, 0)), f.x),
               mix(bloom_load(level, i + ivec2(0, 1)), bloom_load(level, i + ivec2(1, 1)), f.x), f.y);
}

#endif
