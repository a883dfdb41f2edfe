// Temporal anti-aliasing's colour arithmetic (render/src/taa): the space history is clipped and
// blended in, and the history filter.
#ifndef TAA_GLSL
#define TAA_GLSL

// Colours are compressed by 1/(1 + max channel) for the neighbourhood's statistics (Karis,
// "High Quality Temporal Supersampling", 2014): a lone bright pixel then weighs like a white
// one instead of stretching the box over everything. The blend itself is linear: blending
// compressed colours (Karis's weighting) darkened every partly covered edge pixel, a third
// more error against a supersampled image in tests/tests/antialiasing.rs.
vec3 taa_compress(vec3 c) {
    return c / (1.0 + max(c.r, max(c.g, c.b)));
}

vec3 taa_expand(vec3 c) {
    return c / max(1.0 - max(c.r, max(c.g, c.b)), 1.0 / 65504.0);
}

// YCoCg: luma and two chroma axes, in which a neighbourhood's box hugs its colours more tightly
// than in RGB (Karis 2014).
vec3 rgb_to_ycocg(vec3 c) {
    return vec3(dot(c, vec3(0.25, 0.5, 0.25)), dot(c, vec3(0.5, 0.0, -0.5)), dot(c, vec3(-0.25, 0.5, -0.25)));
}

vec3 ycocg_to_rgb(vec3 c) {
    return vec3(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z);
}

// Moves `history` towards the box's centre `center` until it lies inside [lo, hi] (clipping
// keeps its hue where clamping each axis would not).
vec3 clip_to_box(vec3 history, vec3 center, vec3 lo, vec3 hi) {
    vec3 extent = max(hi - lo, vec3(1e-5)) * 0.5;
    vec3 offset = history - center;
    vec3 units = abs(offset / extent);
    float most = max(units.x, max(units.y, units.z));
    return most > 1.0 ? center + offset / most : history;
}

// Bicubic Catmull-Rom filtering of `tex` at `uv` from five bilinear taps (the 16 texels' weights
// folded pairwise; corners left out): a sharper history than one bilinear tap, which blurs a
// little more every frame it is reprojected.
vec3 sample_catmull_rom(sampler2D tex, vec2 uv, vec2 size) {
    vec2 pos = uv * size;
    vec2 center = floor(pos - 0.5) + 0.5;
    vec2 f = pos - center;
    vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
    vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
    vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
    vec2 w3 = f * f * (-0.5 + 0.5 * f);
    vec2 w12 = w1 + w2;
    vec2 t0 = (center - 1.0) / size;
    vec2 t3 = (center + 2.0) / size;
    vec2 t12 = (center + w2 / w12) / size;
    float wa = w12.x * w0.y, wb = w0.x * w12.y, wc = w12.x * w12.y, wd = w3.x * w12.y, we = w12.x * w3.y;
    vec3 sum = texture(tex, vec2(t12.x, t0.y)).rgb * wa + texture(tex, vec2(t0.x, t12.y)).rgb * wb + texture(tex, t12).rgb * wc
        + texture(tex, vec2(t3.x, t12.y)).rgb * wd + texture(tex, vec2(t12.x, t3.y)).rgb * we;
    return max(sum / (wa + wb + wc + wd + we), vec3(0.0));
}

#endif
