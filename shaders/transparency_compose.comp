// variants: SEED_PAIRS
#version 460
// Interlaced transparency, composition (seed 002 §2.4.2, §3.1 eq. 3.3, refraction §3.3).
// After lighting, odd rows hold the lit nearest blended surface where there is one (opacity < 1
// in the G-buffer) and even rows the lit opaque surface; the lit image was copied into
// `transparency_source`, and every pixel of the HDR target is rewritten here as
//   C = α·T + (1 − α)·O
// with T the blended surface's radiance and α its opacity, O the opaque radiance behind it.
//
// The seed blends each pair of rows (2k, 2k+1) into one colour, halving the vertical resolution
// wherever glass is. Here each pixel keeps its own sample for the layer its row holds and
// takes only the other layer from its vertical neighbours:
// - an odd (glass) pixel takes O from the rows above and below, averaged when both lie behind
//   the glass on one surface (their depths agree within 2 %), else from the one above (the
//   seed's partner row) when it lies behind the glass, else from the one below;
// - an even (opaque) pixel takes T and α from the odd rows above and below, averaged when both
//   hold glass in front of this pixel and agree in depth, else the pair partner's (row + 1)
//   when it holds glass in front of this pixel; glass behind this pixel's opaque surface (an
//   object in front of the window) is never blended over it: the depth check.
// Refraction (§3.3, include/refraction.glsl): O is looked up at an offset along the glass
// normal's screen-space direction; a displaced sample whose opaque surface lies in front of the
// glass is rejected and the undisplaced one used instead, so nothing in front of the glass
// ever shows through it.
// SEED_PAIRS: the seed's own composition, for comparison (TransparencyMethod::InterlacedPairs):
// both rows of a pair (2k, 2k+1) get α·T(2k+1) + (1 − α)·O(2k), without depth checks or
// refraction.
#include "scene.glsl"
#include "refraction.glsl"
#include "storable.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform writeonly image2D hdr_image;

ivec2 image_size() { return ivec2(scene.camera.camera.viewport_size); }
bool inside(ivec2 p) { return all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, image_size())); }
float depth_of(ivec2 p) { return texelFetch(depth_target, p, 0).r; }
vec3 lit(ivec2 p) { return texelFetch(transparency_source, p, 0).rgb; }

// Opacity of the blended surface an odd row holds at p; 1 where it holds none.
float glass_opacity(ivec2 p) {
    if (!inside(p) || (p.y & 1) == 0 || depth_of(p) <= 0.0) return 1.0;
    return texelFetch(gbuffer_material, p, 0).b;
}

bool same_surface(float a, float b) { return abs(a - b) <= 0.02 * max(a, b); }

// The opaque radiance behind glass of depth `glass_depth` at p: p itself on an even row, the
// even rows above and below on an odd one. False when no opaque sample there lies behind it.
bool opaque_behind(ivec2 p, float glass_depth, out vec3 o) {
    if ((p.y & 1) == 0) {
        o = lit(p);
        return inside(p) && depth_of(p) < glass_depth;
    }
    ivec2 up = p - ivec2(0, 1), down = p + ivec2(0, 1);
    bool u = inside(up) && depth_of(up) < glass_depth;
    bool d = inside(down) && depth_of(down) < glass_depth;
    if (u && d && same_surface(depth_of(up), depth_of(down))) {
        o = 0.5 * (lit(up) + lit(down));
    } else if (u || d) {
        o = lit(u ? up : down);   // the seed's partner row first
    } else {
        o = vec3(0.0);
    }
    return u || d;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(px)) return;
    bool odd = (px.y & 1) == 1;
    vec3 own = lit(px);
#ifdef SEED_PAIRS
    ivec2 glass_px = ivec2(px.x, px.y | 1), opaque_px = ivec2(px.x, px.y & ~1);
    float pair_alpha = glass_opacity(glass_px);
    vec3 pair = pair_alpha * lit(glass_px) + (1.0 - pair_alpha) * lit(opaque_px);
    imageStore(hdr_image, px, vec4(storable_radiance(pair_alpha >= 1.0 ? own : pair), 1.0));
    return;
#endif

    // The blended layer at px: its opacity, radiance, depth and the pixel holding it.
    float alpha = 1.0;
    vec3 glass = vec3(0.0);
    ivec2 at = px;
    if (odd) {
        alpha = glass_opacity(px);
        glass = own;
    } else {
        float d = depth_of(px);
        ivec2 up = px - ivec2(0, 1), down = px + ivec2(0, 1);
        float au = glass_opacity(up), ad = glass_opacity(down);
        bool u = au < 1.0 && depth_of(up) > d;
        bool dn = ad < 1.0 && depth_of(down) > d;
        if (u && dn && same_surface(depth_of(up), depth_of(down))) {
            alpha = 0.5 * (au + ad);
            glass = 0.5 * (lit(up) + lit(down));
            at = down;
        } else if (dn) {
            alpha = ad;
            glass = lit(down);
            at = down;
        }
    }
    if (alpha >= 1.0) {
        imageStore(hdr_image, px, vec4(storable_radiance(own), 1.0));
        return;
    }

    float glass_depth = depth_of(at);
    vec3 background;
    if (!opaque_behind(px, glass_depth, background)) background = own;
    vec3 n = texelFetch(gbuffer_normal, at, 0).xyz * 2.0 - 1.0;
    ivec2 offset = refraction_offset(n, glass_depth, texelFetch(gbuffer_material, at, 0).a);
    if (offset != ivec2(0)) {
        ivec2 q = px + offset;
        vec3 displaced;
        // The depth check: a displaced sample in front of the glass (or off the image) is not
        // what the glass shows; the undisplaced background stays.
        if (inside(q) && opaque_behind(q, glass_depth, displaced)) background = displaced;
    }
    imageStore(hdr_image, px, vec4(storable_radiance(alpha * glass + (1.0 - alpha) * background), 1.0));
}
