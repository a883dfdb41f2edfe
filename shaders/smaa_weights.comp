#version 460
// SMAA's second pass (render/src/smaa, include/smaa.glsl): for the edges on each pixel's top and
// left sides, the search to both ends of the edge and for the crossing edges there, and the
// areas the re-vectorised silhouette gives the pixel and its neighbour across the edge.
#include "scene.glsl"
#include "smaa.glsl"

layout(set = 0, binding = BINDING_SMAA_EDGES, rgba8) uniform readonly image2D edges_in;
layout(set = 0, binding = BINDING_SMAA_WEIGHTS, rgba8) uniform writeonly image2D weights_out;
layout(local_size_x = 8, local_size_y = 8) in;

ivec2 size;

// The edges of pixel `p` (x left side, y top side); none outside the image.
vec2 edges_at(ivec2 p) {
    return any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size)) ? vec2(0.0) : imageLoad(edges_in, p).xy;
}

// An edge along `along` (1, 0: on top sides; 0, 1: on left sides) through pixel `px`: how many
// pixels it runs before `px` and after it (within the search), and its anchors at both ends.
// `across` is one step to the first side (up for a horizontal edge, left for a vertical one);
// `c` picks the edges component that runs along it (y: top sides, x: left sides) and `k` the
// crossing one.
vec2 edge_weights(ivec2 px, ivec2 along, ivec2 across, int c, int k) {
    ivec2 p = px;
    float start = 0.0;
    int before = 0;
    for (; before < SMAA_SEARCH; ++before) {
        // Crossing edges at the start side of `p`: in the first row (or column) and the second.
        float first = edges_at(p + across)[k], second = edges_at(p)[k];
        if (first + second > 0.5) {
            start = smaa_anchor(first, second);
            break;
        }
        if (edges_at(p - along)[c] < 0.5) break;
        p -= along;
    }
    p = px;
    float end = 0.0;
    int after = 0;
    for (; after < SMAA_SEARCH; ++after) {
        float first = edges_at(p + along + across)[k], second = edges_at(p + along)[k];
        if (first + second > 0.5) {
            end = smaa_anchor(first, second);
            break;
        }
        if (edges_at(p + along)[c] < 0.5) break;
        p += along;
    }
    return smaa_area(float(before), float(before + after + 1), start, end);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    size = imageSize(edges_in);
    if (any(greaterThanEqual(px, size))) return;
    vec2 e = edges_at(px);
    vec4 weights = vec4(0.0);
    // The area above the edge (the first side) is what the neighbour across takes of this
    // pixel's colour; below it, what this pixel takes of the neighbour's.
    if (e.y > 0.5) weights.yx = edge_weights(px, ivec2(1, 0), ivec2(0, -1), 1, 0);
    if (e.x > 0.5) weights.wz = edge_weights(px, ivec2(0, 1), ivec2(-1, 0), 0, 1);
    imageStore(weights_out, px, weights);
}
