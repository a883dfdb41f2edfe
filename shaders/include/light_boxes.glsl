// Ray-query lights (seed 000 §5.2.5, §6.1): every light with a finite range is found through an
// axis-aligned box around its reach, box i for light slot i, in the lights' own acceleration
// structure; a zero-length ray from a surface point enumerates the boxes holding it. Lights no
// box can hold (directional lights, unbounded ranges) are listed apart and looped over by every
// pixel. The seed cut a light off at its box, which left box-shaped seams; here a light's
// contribution reaches zero at its range (lighting.glsl's window) and the box holds the whole
// range sphere (or, for a spot, the part of it inside the cone), so a box never cuts anything.
#ifndef LIGHT_BOXES_GLSL
#define LIGHT_BOXES_GLSL

#include "scene.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer LightBoxesRef { GpuAabb boxes[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer UnboundedLightsRef {
    uint count;
    uint slots[];
};

// Ranges from here on are treated as unbounded (a box that large would hold every pixel anyway).
const float LIGHT_BOX_MAX_RANGE = 1e6;

bool light_position_finite(GpuLight light) {
    return !any(isnan(light.position)) && !any(isinf(light.position));
}

// Whether the light has a position and reaches as far as its range from it (point, spot and
// area lights).
bool light_is_placed(GpuLight light) {
    return light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT || light.kind == LIGHT_RECT || light.kind == LIGHT_DISK;
}

// Whether the light is found through its box (placed lights with a finite range).
bool light_is_boxed(GpuLight light) {
    return light_is_placed(light) && light.range > 0.0 && light.range < LIGHT_BOX_MAX_RANGE && light_position_finite(light);
}

// Whether the light is looped over by every pixel.
bool light_is_unbounded(GpuLight light) {
    return light.kind == LIGHT_DIRECTIONAL || (light_is_placed(light) && !(light.range < LIGHT_BOX_MAX_RANGE) && light_position_finite(light));
}

// The exact test behind a box: the light is boxed and `p` is within its range.
bool light_box_holds(GpuLight light, vec3 p) {
    if (!light_is_boxed(light)) return false;
    vec3 d = light.position - p;
    return dot(d, d) < light.range * light.range;
}

// The box around a boxed light's reach: its range sphere's box, narrowed for a spot light whose
// cone is narrower than a hemisphere to the box of the cone cut at the range along its axis
// (the hull of the tip and that disc), which holds every point within range inside the cone.
void light_box(GpuLight light, out vec3 lo, out vec3 hi) {
    vec3 r = vec3(light.range);
    lo = light.position - r;
    hi = light.position + r;
    if (light.kind == LIGHT_SPOT && light.cone_cos > 0.05) {
        vec3 d = light.direction;
        vec3 centre = light.position + d * light.range;
        vec3 e = light.range * (light.cone_sin / light.cone_cos) * sqrt(max(vec3(1.0) - d * d, vec3(0.0)));
        lo = max(lo, min(light.position, centre - e));
        hi = min(hi, max(light.position, centre + e));
    }
}

#endif
