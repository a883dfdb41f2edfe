// Tiled light culling (seed 001 §4.2) and the shadow bits (§4.3), as every pass that reads them
// sees them. The light tile buffer (32-bit words, GpuLighting::light_tiles):
//   [0, LIGHT_TILE_HEADER)   statistics (below), read back by the CPU
//   grid[tiles] × 3          per tile: offset into the list, count, first shadow row
//   list[list_capacity]      light slots, tile after tile (the seed's light index list)
// A tile's count with LIGHT_TILE_OVERFLOW set did not fit the list: its pixels loop over every
// light, unshadowed, until the renderer grows the buffer (two frames later); a tile whose first
// shadow row is NO_SHADOW_ROWS got list entries but no shadow words. Both are counted.
//
// Shadow words (GpuLighting::shadow_bits): a row is one 32-bit word per pixel of a tile, for 32
// entries of its list; bit k of the word of pixel p in row r + j/32 says whether list entry
// j = 32·(j/32) + k reaches p unblocked. With every light (LIGHTS_ALL) tile t has the rows
// t·⌈lights/32⌉ onwards. The seed stored one 32-bit word per pixel and so capped a tile at 32
// lights; rows lift the cap.
//
// Shadow tints (GpuLighting::shadow_tints, coloured shadows with glass in the scene): per pixel,
// SHADOW_TINT_SLOTS words, each the RGB8 transmittance of one set bit's light and, in the top 8
// bits, 1 + its list entry (0: empty). A lit entry with no slot is lit untinted; the shadow pass
// gives a pixel's further tinted entries (and entries past 254) the bit of the tint's luminance.
#ifndef LIGHT_TILES_GLSL
#define LIGHT_TILES_GLSL

#include "scene.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) buffer LightTileWordsRef { uint words[]; };
// The same words as the passes after light culling read them: read-only, so that the shading
// loops' loads of the lists may take the non-coherent cache path.
layout(buffer_reference, std430, buffer_reference_align = 4) readonly restrict buffer LightListRef { uint words[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer TileFrustaRef { GpuTileFrustum frusta[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ShadowWordsRef { uint words[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer ShadowTintsRef { uint words[]; };

const uint LSTAT_ENTRIES = 0u;      // list entries the tiles needed
const uint LSTAT_ROWS = 1u;         // shadow rows the tiles needed
const uint LSTAT_OVERFLOWED = 2u;   // tiles whose list or shadow rows did not fit
const uint LSTAT_MAX = 3u;          // most lights in one tile
const uint LSTAT_TILES_USED = 4u;   // tiles holding any light
const uint LSTAT_SAMPLED = 5u;      // tiles whose pixels sample their lights' shadows (direct_sampling.glsl)
// Raised by every cull and never cleared (the header's last word): a frame count the GPU keeps,
// which the sampled shadows' draws hash (direct_sampling.glsl) without an upload a frame.
const uint LSTAT_FRAME = LIGHT_TILE_HEADER - 1u;
const uint NO_SHADOW_ROWS = 0xFFFFFFFFu;

uint tile_pixels() {
    uint ts = scene.lighting.lighting.tile_size;
    return ts * ts;
}

uint tile_of(ivec2 px) {
    uvec2 t = uvec2(px) / scene.lighting.lighting.tile_size;
    return t.y * scene.lighting.lighting.tiles_x + t.x;
}

uint pixel_in_tile(ivec2 px) {
    uint ts = scene.lighting.lighting.tile_size;
    uvec2 p = uvec2(px) % ts;
    return p.y * ts + p.x;
}

uint grid_at(uint tile) { return LIGHT_TILE_HEADER + 3u * tile; }
uint list_at() {
    GpuLighting l = scene.lighting.lighting;
    return LIGHT_TILE_HEADER + 3u * l.tiles_x * l.tiles_y;
}

LightTileWordsRef light_tile_words() { return LightTileWordsRef(scene.lighting.lighting.light_tiles); }
LightListRef light_list_words() { return LightListRef(scene.lighting.lighting.light_tiles); }

// The lights a pixel loops over: list entries [0, count), through the tile's list (from word
// `offset` of the light tile words, resolved once rather than a light at a time) when
// `indexed`, else light slots 0..count; `rows` is the first shadow row (NO_SHADOW_ROWS: none).
struct LightList {
    uint offset;
    uint count;
    bool indexed;
    uint rows;
};

LightList light_list(ivec2 px) {
    GpuLighting l = scene.lighting.lighting;
    LightList r;
    uint tile = tile_of(px);
    bool traced = (l.flags & SHADOWS_TRACED) != 0u;
    if (l.mode == LIGHTS_TILED) {
        uint g = grid_at(tile);
        LightListRef w = light_list_words();
        uint count = w.words[g + 1u];
        if ((count & LIGHT_TILE_OVERFLOW) != 0u) {
            r.offset = 0u;
            r.count = l.light_count;
            r.indexed = false;
            r.rows = NO_SHADOW_ROWS;
        } else {
            r.offset = list_at() + w.words[g];
            r.count = count;
            r.indexed = true;
            r.rows = traced ? w.words[g + 2u] : NO_SHADOW_ROWS;
        }
    } else {
        r.offset = 0u;
        r.count = l.light_count;
        r.indexed = false;
        r.rows = traced ? tile * ((l.light_count + 31u) / 32u) : NO_SHADOW_ROWS;
    }
    return r;
}

uint light_slot(LightList list, uint j) {
    return list.indexed ? light_list_words().words[list.offset + j] : j;
}

// Index of the shadow word holding entry j (and the 31 after it in its row) for pixel `px`.
uint shadow_word_at(LightList list, uint j, ivec2 px) {
    return (list.rows + j / 32u) * tile_pixels() + pixel_in_tile(px);
}

// The glass layer (GLASS_SHADOWS: forward transparency with shadows): a second set of shadow
// words and tints after the first, for the nearest blended surface, written by the shadow
// pass's GLASS_LAYER variant over the transparent depth. These are its offsets, in words.
uint glass_layer_words() {
    return scene.lighting.lighting.shadow_rows * tile_pixels();
}
uint glass_layer_tints() {
    uvec2 size = uvec2(scene.camera.camera.viewport_size);
    return size.x * size.y * SHADOW_TINT_SLOTS;
}

// Index of pixel `px`'s first shadow tint word.
uint shadow_tint_at(ivec2 px) {
    return (uint(px.y) * uint(scene.camera.camera.viewport_size.x) + uint(px.x)) * SHADOW_TINT_SLOTS;
}

// The tint of list entry j at a pixel whose tint words start at word `at` of the shadow tints
// (white when it has none).
vec3 shadow_tint_of(uint at, uint j) {
    ShadowTintsRef words = ShadowTintsRef(scene.lighting.lighting.shadow_tints);
    for (uint s = 0u; s < SHADOW_TINT_SLOTS; ++s) {
        uint t = words.words[at + s];
        if ((t >> 24) == j + 1u) return unpackUnorm4x8(t).rgb;
    }
    return vec3(1.0);
}

#endif
