// Fast approximate anti-aliasing (Lottes, "FXAA", NVIDIA white paper 2009, and the 3.11 quality
// preset's structure): a post-process over the displayed image that finds where luma changes
// sharply, decides whether the edge runs across or along the pixel, walks along it to both ends
// to estimate where the stair step is, and re-samples the image that far towards the other side
// of the edge with bilinear filtering; sub-pixel aliasing (a pixel unlike all its neighbours)
// gets a blend of its own. Written here from the published description.
//
// The including shader defines `vec3 fxaa_display(vec2 uv)`: the displayed colour at `uv`
// (fxaa.comp samples the HDR target bilinearly and tone maps it, so every tap is what the
// screen shows). Luma is taken perceptually (the square root of linear luminance, near sRGB's).
#ifndef FXAA_GLSL
#define FXAA_GLSL

#include "color.glsl"

vec3 fxaa_display(vec2 uv);

const float FXAA_EDGE_THRESHOLD = 0.125;        // the local contrast an edge needs, relative
const float FXAA_EDGE_THRESHOLD_MIN = 0.0312;   // ... and absolute (dark areas stay untouched)
const float FXAA_SUBPIXEL = 0.75;               // how much a lone pixel blends with its neighbours
const int FXAA_SEARCH_STEPS = 10;
const float FXAA_SEARCH_STRIDE[FXAA_SEARCH_STEPS] = float[](1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 4.0, 8.0);

float fxaa_luma(vec3 display) {
    return sqrt(max(luminance(display), 0.0));
}

float fxaa_luma_at(vec2 uv) {
    return fxaa_luma(fxaa_display(uv));
}

// The anti-aliased colour of the pixel centred at `uv`; `texel` is one pixel in uv.
vec3 fxaa(vec2 uv, vec2 texel) {
    vec3 centre = fxaa_display(uv);
    float c = fxaa_luma(centre);
    float n = fxaa_luma_at(uv + vec2(0.0, -texel.y));
    float s = fxaa_luma_at(uv + vec2(0.0, texel.y));
    float w = fxaa_luma_at(uv + vec2(-texel.x, 0.0));
    float e = fxaa_luma_at(uv + vec2(texel.x, 0.0));
    float lo = min(c, min(min(n, s), min(w, e)));
    float hi = max(c, max(max(n, s), max(w, e)));
    float range = hi - lo;
    if (range < max(FXAA_EDGE_THRESHOLD_MIN, hi * FXAA_EDGE_THRESHOLD)) return centre;

    float nw = fxaa_luma_at(uv + vec2(-texel.x, -texel.y));
    float ne = fxaa_luma_at(uv + vec2(texel.x, -texel.y));
    float sw = fxaa_luma_at(uv + vec2(-texel.x, texel.y));
    float se = fxaa_luma_at(uv + vec2(texel.x, texel.y));

    // Sub-pixel aliasing: how far the pixel stands out from the average around it.
    float average = (2.0 * (n + s + w + e) + nw + ne + sw + se) / 12.0;
    float lone = clamp(abs(average - c) / range, 0.0, 1.0);
    float subpixel = smoothstep(0.0, 1.0, lone);
    subpixel = subpixel * subpixel * FXAA_SUBPIXEL;

    // Which way the edge runs: second differences across rows (a horizontal edge) and columns.
    float across_rows = abs(nw - 2.0 * w + sw) + 2.0 * abs(n - 2.0 * c + s) + abs(ne - 2.0 * e + se);
    float across_columns = abs(nw - 2.0 * n + ne) + 2.0 * abs(w - 2.0 * c + e) + abs(sw - 2.0 * s + se);
    bool horizontal = across_columns >= across_rows;

    // The side of the edge with the larger step, and a half-pixel step onto the edge.
    float before = horizontal ? n : w;
    float after = horizontal ? s : e;
    float gradient_before = abs(before - c);
    float gradient_after = abs(after - c);
    float step_length = horizontal ? texel.y : texel.x;
    float side_luma;
    if (gradient_before >= gradient_after) {
        step_length = -step_length;
        side_luma = before;
    } else {
        side_luma = after;
    }
    float gradient = 0.25 * max(gradient_before, gradient_after);
    float edge_luma = 0.5 * (c + side_luma);
    vec2 along = horizontal ? vec2(texel.x, 0.0) : vec2(0.0, texel.y);
    vec2 on_edge = uv + (horizontal ? vec2(0.0, step_length * 0.5) : vec2(step_length * 0.5, 0.0));

    // Walk along the edge both ways until the luma leaves the edge's average.
    vec2 p1 = on_edge - along, p2 = on_edge + along;
    float end1 = fxaa_luma_at(p1) - edge_luma, end2 = fxaa_luma_at(p2) - edge_luma;
    bool done1 = abs(end1) >= gradient, done2 = abs(end2) >= gradient;
    for (int i = 1; i < FXAA_SEARCH_STEPS && !(done1 && done2); ++i) {
        if (!done1) {
            p1 -= along * FXAA_SEARCH_STRIDE[i];
            end1 = fxaa_luma_at(p1) - edge_luma;
            done1 = abs(end1) >= gradient;
        }
        if (!done2) {
            p2 += along * FXAA_SEARCH_STRIDE[i];
            end2 = fxaa_luma_at(p2) - edge_luma;
            done2 = abs(end2) >= gradient;
        }
    }
    float distance1 = horizontal ? uv.x - p1.x : uv.y - p1.y;
    float distance2 = horizontal ? p2.x - uv.x : p2.y - uv.y;
    bool nearer1 = distance1 < distance2;
    float nearest = min(distance1, distance2);
    float span = distance1 + distance2;
    // Blend only when the nearer end turns the way the centre does (the step is on this side).
    bool centre_below = c < edge_luma;
    bool consistent = ((nearer1 ? end1 : end2) < 0.0) != centre_below;
    float edge_offset = consistent ? 0.5 - nearest / span : 0.0;

    float offset = max(edge_offset, subpixel);
    vec2 moved = uv + (horizontal ? vec2(0.0, offset * step_length) : vec2(offset * step_length, 0.0));
    return fxaa_display(moved);
}

#endif
