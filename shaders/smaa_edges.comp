#version 460
// SMAA's first pass (render/src/smaa, include/smaa.glsl): each pixel's edges on its left and top
// sides, from the displayed image's luma, kept where local contrast adaptation allows.
#include "display.glsl"
#include "smaa.glsl"

layout(set = 0, binding = BINDING_SMAA_EDGES, rgba8) uniform writeonly image2D edges_out;
layout(local_size_x = 8, local_size_y = 8) in;

float luma_at(ivec2 p) {
    return smaa_luma(display_texel(p));
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, textureSize(hdr_target, 0)))) return;
    float l = luma_at(px);
    float left = luma_at(px - ivec2(1, 0));
    float top = luma_at(px - ivec2(0, 1));
    // The image's first column and row have no neighbour there: the clamped fetch is the pixel
    // itself, no contrast.
    vec2 contrast = abs(vec2(l - left, l - top));
    vec2 edges = step(SMAA_THRESHOLD, contrast);
    if (edges.x + edges.y > 0.0) {
        float strongest = max(contrast.x, contrast.y);
        strongest = max(strongest, abs(l - luma_at(px + ivec2(1, 0))));
        strongest = max(strongest, abs(l - luma_at(px + ivec2(0, 1))));
        strongest = max(strongest, abs(left - luma_at(px - ivec2(2, 0))));
        strongest = max(strongest, abs(top - luma_at(px - ivec2(0, 2))));
        edges *= step(strongest, SMAA_ADAPTATION * contrast);
    }
    imageStore(edges_out, px, vec4(edges, 0.0, 0.0));
}
