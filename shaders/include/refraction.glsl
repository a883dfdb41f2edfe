// Refraction with a depth check (seed 002 §3.3), shared by the transparency compositions
// (transparency_compose.comp, transparency_peeled.comp): the background behind glass is looked
// up at an offset along the glass normal's screen-space direction, the material's refraction
// (metres at the surface) projected to pixels at the glass's distance. The compositions reject
// a displaced sample whose surface lies in front of the glass.
#ifndef REFRACTION_GLSL
#define REFRACTION_GLSL

#include "scene.glsl"

// The displacement in pixels of the background lookup behind glass at reverse-Z depth
// `glass_depth` with world-space normal `n`, whose G-buffer holds `refraction` (0..1 over
// 0..REFRACTION_MAX_MM). Zero when refraction is off or the material does not refract.
ivec2 refraction_offset(vec3 n, float glass_depth, float refraction) {
    float metres = refraction * float(REFRACTION_MAX_MM) * 1e-3;
    if (metres <= 0.0 || (scene.lighting.lighting.flags & REFRACTION) == 0u) return ivec2(0);
    GpuCamera cam = scene.camera.camera;
    vec3 nv = mat3(cam.view) * n;
    float view_distance = cam.proj[3][2] / (glass_depth + cam.proj[2][2]);
    float pixels = metres * cam.proj[1][1] * 0.5 * cam.viewport_size.y / max(view_distance, 1e-4);
    // Image rows grow downwards, view-space y upwards.
    return ivec2(round(vec2(nv.x, -nv.y) * pixels));
}

#endif
