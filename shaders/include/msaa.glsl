// MSAA's per-pixel inputs (render/src/msaa): every screen-space pass works on the surface of
// each pixel's sample 0 (the depth target is resolved to it). A fragment of another surface at
// an edge pixel reads those inputs at the pixel beside it that holds its own surface: the pixel
// of the 3×3 around it whose sample-0 depth is nearest its own depth (the pixel itself when that
// is within 1 %: sample 0 sits off the pixel's centre, where the fragment's depth is taken).
// Sky pixels are never chosen (the per-pixel passes skip them); a sliver of geometry with only
// sky at sample 0 all around keeps its own pixel.
#ifndef MSAA_GLSL
#define MSAA_GLSL

#include "depth.glsl"

ivec2 msaa_surface_pixel(ivec2 px, float z) {
    float own = abs(depth_at(px) - z);
    if (own <= 0.01 * z) return px;
    ivec2 best = px;
    float best_difference = own;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(px + ivec2(dx, dy), ivec2(0), ivec2(scene.camera.camera.viewport_size) - 1);
            float depth = depth_at(q);
            float difference = abs(depth - z);
            if (depth > 0.0 && difference < best_difference) {
                best = q;
                best_difference = difference;
            }
        }
    }
    return best;
}

#endif
