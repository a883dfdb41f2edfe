// variants: HISTORY_B
#version 460
// Temporal anti-aliasing's output (render/src/taa): the resolved history copied back into the
// HDR target for bloom, exposure and tone mapping, sharpened when asked (the strength in the
// high 16 bits of the push word): the pixel less its four neighbours' mean, limited to their
// range so that edges do not ring. The history itself stays unsharpened, or sharpening would
// compound frame after frame.
// Variant HISTORY_B follows the resolve variant that wrote history A.
#include "scene.glsl"
#include "storable.glsl"

#ifdef HISTORY_B
layout(set = 0, binding = BINDING_TAA_HISTORY_A_STORAGE, rgba16f) uniform readonly image2D resolved;
#else
layout(set = 0, binding = BINDING_TAA_HISTORY_B_STORAGE, rgba16f) uniform readonly image2D resolved;
#endif
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform writeonly image2D hdr_image;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 size = imageSize(resolved);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, size))) return;
    vec3 c = imageLoad(resolved, px).rgb;
    float strength = float(scene.texture_index >> TAA_SHARPEN_SHIFT) / 65535.0;
    if (strength > 0.0) {
        vec3 n = imageLoad(resolved, clamp(px + ivec2(0, -1), ivec2(0), size - 1)).rgb;
        vec3 s = imageLoad(resolved, clamp(px + ivec2(0, 1), ivec2(0), size - 1)).rgb;
        vec3 e = imageLoad(resolved, clamp(px + ivec2(1, 0), ivec2(0), size - 1)).rgb;
        vec3 w = imageLoad(resolved, clamp(px + ivec2(-1, 0), ivec2(0), size - 1)).rgb;
        vec3 lo = min(min(min(n, s), min(e, w)), c);
        vec3 hi = max(max(max(n, s), max(e, w)), c);
        c = clamp(c + strength * (c - (n + s + e + w) * 0.25), lo, hi);
    }
    imageStore(hdr_image, px, vec4(storable_radiance(c), 1.0));
}
