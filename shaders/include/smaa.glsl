// SMAA 1x (Jimenez, Echevarria, Sousa and Gutierrez, "SMAA: Enhanced Subpixel Morphological
// Antialiasing", Eurographics 2012), orthogonal patterns, written here from the paper and from
// Reshetov's MLAA (HPG 2009) that it builds on: edges by luma with local contrast adaptation;
// along each edge a search to both ends and for the crossing edges there, which give the shape
// the stair step stands for (an L, a Z or a U); the silhouette re-vectorised as lines through the
// middle of each step, and each pixel blended with its neighbour across the edge by the area of
// its side the line cuts off. The paper reads that area from a precomputed texture indexed by
// the two distances and crossings; here it is computed in the shader (a few multiplications,
// only at edge pixels), which needs no texture and gives the same areas. Diagonal patterns and
// corner rounding, optional in the paper, are left out.
#ifndef SMAA_GLSL
#define SMAA_GLSL

#include "color.glsl"

// Luma contrast an edge needs (the paper's default, for gamma-encoded luma).
const float SMAA_THRESHOLD = 0.1;
// An edge is kept only where its contrast is at least 1/SMAA_ADAPTATION of the strongest
// contrast around it (local contrast adaptation: the weaker edge of a thin line is not
// blended towards the stronger).
const float SMAA_ADAPTATION = 2.0;
// Pixels searched along an edge each way (the paper's high preset searches 16 texel pairs).
const int SMAA_SEARCH = 32;

// Perceptual luma (the square root of linear luminance, near sRGB's encoding).
float smaa_luma(vec3 display) {
    return sqrt(max(luminance(display), 0.0));
}

// Where the re-vectorised silhouette starts at an end of an edge: half a pixel to the side that
// the crossing edge there is on (`first`: the row above a horizontal edge, the column left of a
// vertical one; `second`: the other), or on the edge itself when there is no crossing or one
// on both sides (a T, which is no stair step).
float smaa_anchor(float first, float second) {
    return first > 0.5 && second < 0.5 ? 0.5 : second > 0.5 && first < 0.5 ? -0.5 : 0.0;
}

// The parts of [a, b] × (the line from (x0, y0) to (x1, y1), clipped to [x0, x1]) above zero (x)
// and below it (y), as areas.
vec2 smaa_line_area(float a, float b, float x0, float y0, float x1, float y1) {
    a = max(a, x0);
    b = min(b, x1);
    if (b <= a) return vec2(0.0);
    float ya = mix(y0, y1, (a - x0) / (x1 - x0));
    float yb = mix(y0, y1, (b - x0) / (x1 - x0));
    if (ya >= 0.0 && yb >= 0.0) return vec2(0.5 * (ya + yb) * (b - a), 0.0);
    if (ya <= 0.0 && yb <= 0.0) return vec2(0.0, -0.5 * (ya + yb) * (b - a));
    float root = a + (b - a) * ya / (ya - yb);
    vec2 triangles = vec2(0.5 * abs(ya) * (root - a), 0.5 * abs(yb) * (b - root));
    return ya > 0.0 ? triangles : triangles.yx;
}

// The area the re-vectorised silhouette of an edge `span` pixels long cuts off the pixel
// `before` pixels from its start, on the first side (x) and the second (y), given its anchors
// at the start and the end (smaa_anchor). An L (one anchor) runs from its anchor to the middle
// of the edge; a Z (anchors on opposite sides) is one line end to end; a U (both on one side)
// is two Ls.
vec2 smaa_area(float before, float span, float start, float end) {
    float a = before, b = before + 1.0, middle = 0.5 * span;
    if (start * end < 0.0) return smaa_line_area(a, b, 0.0, start, span, end);
    vec2 area = vec2(0.0);
    if (start != 0.0) area += smaa_line_area(a, b, 0.0, start, middle, 0.0);
    if (end != 0.0) area += smaa_line_area(a, b, middle, 0.0, span, end);
    return area;
}

#endif
