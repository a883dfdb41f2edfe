#version 460
// SMAA's third pass (render/src/smaa, include/smaa.glsl): each pixel blends with its four
// neighbours by the weights of the edges between them, in the displayed image, into the
// anti-aliased colour target the display pass copies out.
#include "display.glsl"

layout(set = 0, binding = BINDING_SMAA_WEIGHTS, rgba8) uniform readonly image2D weights_in;
layout(set = 0, binding = BINDING_ANTIALIASED_STORAGE, rgba16f) uniform writeonly image2D antialiased_out;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(weights_in);
    if (any(greaterThanEqual(px, size))) return;
    vec4 own = imageLoad(weights_in, px);
    // What this pixel takes of each neighbour: its own weights for the top and left ones, the
    // bottom and right neighbours' for their top and left sides.
    float top = own.x, left = own.z;
    float bottom = px.y + 1 < size.y ? imageLoad(weights_in, px + ivec2(0, 1)).y : 0.0;
    float right = px.x + 1 < size.x ? imageLoad(weights_in, px + ivec2(1, 0)).w : 0.0;
    vec3 color = display_texel(px);
    float total = top + bottom + left + right;
    if (total > 0.0) {
        float scale = 1.0 / max(total, 1.0);
        vec3 neighbours = top * display_texel(px - ivec2(0, 1)) + bottom * display_texel(px + ivec2(0, 1))
            + left * display_texel(px - ivec2(1, 0)) + right * display_texel(px + ivec2(1, 0));
        color = color * (1.0 - total * scale) + neighbours * scale;
    }
    imageStore(antialiased_out, px, vec4(color, 1.0));
}
