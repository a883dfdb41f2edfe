// The ray-tracing-pipeline decal pass's per-pixel decal lists (render/src/decals/lists.rs), in
// the buffer at scene.decal_lists (scene.decal_list_capacity entries):
//   - a header of DECAL_LIST_HEADER words: the statistics below, the pixels' row width and
//     count, which the renderer writes each frame, and the reservation counter;
//   - each pixel's list: where its first entry is (NO_LIST: none); its entry i is
//     DECAL_LIST_RUN entries after entry i − 1, interleaved with its run's other pixels;
//   - each pixel's count: the decals its rays found last frame, which sizes its room this frame;
//   - each pixel's room: how many entries its list has;
//   - the entries, decal slots, in blocks of DECAL_LIST_RUN neighbouring pixels of a row (their
//     order is whatever order the workgroups of decal_list_offsets.comp reserved them in).
// The first trace's any-hit shader writes each decal it finds into the pixel's room, and the
// ray-generation shader blends them after the trace; a pixel that finds more than its room is
// blended by a second trace, whose any-hit shader blends (the seed's way), so no decal is lost.
#ifndef DECAL_LISTS_GLSL
#define DECAL_LISTS_GLSL

#include "scene.glsl"

layout(buffer_reference, std430, buffer_reference_align = 4) buffer DecalListsRef { uint words[]; };

const uint LIST_NEEDED = 0u;       // entries the runs asked for (saturating at 2³² − 1)
const uint LIST_DENIED = 1u;       // pixels that asked for room and got none (past the capacity)
const uint LIST_OVERFLOWED = 2u;   // pixels that found more decals than their room (traced again)
const uint LIST_WIDTH = 3u;        // pixels in a row
const uint LIST_PIXELS = 4u;       // pixels
const uint LIST_ALLOCATED = 5u;    // entries handed out (the reservation counter)
const uint NO_LIST = 0xFFFFFFFFu;
const uint DECAL_LIST_RUN = 8u;    // pixels of a row whose lists share a block, interleaved

DecalListsRef decal_lists() { return DecalListsRef(scene.decal_lists); }

// The linear index of pixel `px` (NO_LIST outside the lists' image).
uint decal_list_pixel(uvec2 px) {
    DecalListsRef l = decal_lists();
    uint width = l.words[LIST_WIDTH];
    uint p = px.y * width + px.x;
    return px.x < width && p < l.words[LIST_PIXELS] ? p : NO_LIST;
}

uint decal_list_start_at() { return DECAL_LIST_HEADER; }
uint decal_list_found_at() { return DECAL_LIST_HEADER + decal_lists().words[LIST_PIXELS]; }
uint decal_list_room_at() { return DECAL_LIST_HEADER + 2u * decal_lists().words[LIST_PIXELS]; }
uint decal_list_entries_at() { return DECAL_LIST_HEADER + 3u * decal_lists().words[LIST_PIXELS]; }

// The room a pixel asks for this frame, from what it found last frame: an eighth more and two,
// so that a view that moves a little rarely needs the second trace; none for a pixel that found
// none (most pixels, where decals are sparse), which has its run's room all the same.
// A pixel with more than DECAL_LIST_MOST decals blends them the seed's way whatever its room.
const uint DECAL_LIST_MOST = 4096u;
uint decal_list_room(uint found_last) {
    return found_last == 0u ? 0u : min(found_last + found_last / 8u + 2u, DECAL_LIST_MOST);
}

#endif
