// GPU culling (render/src/culling): the records, lists and depth pyramid the culling passes
// share, and the two tests: an axis-aligned box against a view's frustum, and against the
// depth pyramid (hierarchical Z). These shaders have push constants of their own
// (GpuCullPush), so they include the scene's records without its push block.
#ifndef CULLING_GLSL
#define CULLING_GLSL

#define NO_SCENE_PUSH
#include "scene.glsl"
#include "depth_pyramid.glsl"

layout(push_constant) uniform CullPushBlock {
    GpuCullPush cull;
};

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CullParamsRef { GpuCullParams params; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CullRecordsRef { GpuCullRecord records[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer CullWordsRef { uint words[]; };

GpuCullParams cull_params() {
    return CullParamsRef(cull.params).params;
}

// Row r of a column-major matrix.
vec4 matrix_row(mat4 m, int r) {
    return vec4(m[0][r], m[1][r], m[2][r], m[3][r]);
}

// Whether the box [lo, hi] reaches inside the frustum of `view_proj` (reverse-Z clip space:
// −w ≤ x, y ≤ w and 0 ≤ z ≤ w): against each plane the box's corner farthest along the
// plane's normal must lie on the inner side. Conservative: a box that straddles two planes
// outside a frustum corner is kept.
bool in_frustum(mat4 view_proj, vec3 lo, vec3 hi) {
    vec4 r0 = matrix_row(view_proj, 0), r1 = matrix_row(view_proj, 1);
    vec4 r2 = matrix_row(view_proj, 2), r3 = matrix_row(view_proj, 3);
    vec4 planes[6] = vec4[6](r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2);
    vec3 c = (lo + hi) * 0.5, e = (hi - lo) * 0.5;
    for (int i = 0; i < 6; i++) {
        vec4 p = planes[i];
        if (dot(p.xyz, c) + dot(abs(p.xyz), e) + p.w < 0.0) return false;
    }
    return true;
}

// Whether the box [lo, hi], seen through `view_proj` over `viewport` pixels, lies behind
// the depth in the pyramid at `hiz` everywhere it covers: its nearest depth (reverse Z: the
// largest) is below the farthest depth (the smallest) of the at most 2×2 texels of the level
// whose texels are as large as the box on screen. A box reaching behind the eye is never
// occluded.
bool hiz_occluded(mat4 view_proj, vec3 lo, vec3 hi, uint64_t hiz, uvec2 viewport, uint levels) {
    vec3 nmin = vec3(1e30), nmax = vec3(-1e30);
    for (int i = 0; i < 8; i++) {
        vec3 corner = vec3((i & 1) != 0 ? hi.x : lo.x, (i & 2) != 0 ? hi.y : lo.y, (i & 4) != 0 ? hi.z : lo.z);
        vec4 clip = view_proj * vec4(corner, 1.0);
        if (clip.w <= 1e-5) return false;
        vec3 ndc = clip.xyz / clip.w;
        nmin = min(nmin, ndc);
        nmax = max(nmax, ndc);
    }
    if (nmax.z >= 1.0) return false; // reaches the near plane
    vec2 size = vec2(viewport);
    // The viewport is flipped (gpu::pipeline::set_viewport): NDC +y is row 0.
    vec2 pmin = vec2(nmin.x + 1.0, 1.0 - nmax.y) * 0.5 * size;
    vec2 pmax = vec2(nmax.x + 1.0, 1.0 - nmin.y) * 0.5 * size;
    ivec2 imax = ivec2(viewport) - 1;
    // Level-0 texels (2×2 pixels each) the box's pixels fall in.
    uvec2 t0 = uvec2(clamp(ivec2(floor(pmin)), ivec2(0), imax)) >> 1u;
    uvec2 t1 = uvec2(clamp(ivec2(floor(pmax)), ivec2(0), imax)) >> 1u;
    uint level = 0u;
    while (level + 1u < levels && ((t1.x >> level) - (t0.x >> level) > 1u || (t1.y >> level) - (t0.y >> level) > 1u)) level++;
    uvec2 s = hiz_size(viewport, level);
    uint offset = hiz_offset(viewport, level);
    uvec2 a = min(t0 >> level, s - 1u), b = min(t1 >> level, s - 1u);
    HizRef h = HizRef(hiz);
    float farthest = min(min(h.depth[offset + a.y * s.x + a.x], h.depth[offset + a.y * s.x + b.x]),
                         min(h.depth[offset + b.y * s.x + a.x], h.depth[offset + b.y * s.x + b.x]));
    return nmax.z < farthest;
}

// Levels of detail (render/src/lod): pixels on screen per unit of relative error of a mesh whose
// world bounds are [lo, hi], seen through `view_proj` over a viewport `height` pixels high: the
// bounds' diagonal scaled by the projection at the box's nearest clip w (conservative). A box
// reaching the eye plane gets a huge scale (level 0).
float lod_pixels_per_error(mat4 view_proj, vec3 lo, vec3 hi, float height) {
    vec4 r1 = matrix_row(view_proj, 1), r3 = matrix_row(view_proj, 3);
    vec3 c = (lo + hi) * 0.5, e = (hi - lo) * 0.5;
    float w = dot(r3.xyz, c) - dot(abs(r3.xyz), e) + r3.w;
    if (w <= 1e-4) return 1e30;
    return length(hi - lo) * 0.5 * height * length(r1.xyz) / w;
}

// The coarsest level of mesh `m` whose error covers at most `limit` pixels at `scale` pixels per
// unit of relative error (0: the mesh itself).
uint lod_within(GpuMeshInfo m, float scale, float limit) {
    uint level = 0u;
    for (uint k = 0u; k < m.lod_levels; k++) {
        if (m.lod_error[k] * scale > limit) break;
        level = k + 1u;
    }
    return level;
}

#endif
