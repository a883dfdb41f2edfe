#version 460
// Ray-query lights' inputs (light_boxes.glsl), written on the GPU from the light table the
// renderer already keeps, whenever a light changed (render/src/lights/ray_query.rs): box i for
// light slot i; for a slot whose light no box holds (free, directional, unbounded, not finite)
// a zero-size point that belongs to nothing (at its position; a free slot's is the origin); past the slots,
// up to the build's count, points at the lights' positions, spread like the lights (where
// padding lies matters to NVIDIA's builder, docs/BENCHMARKS.md). Unbounded lights are appended
// to their list, which a transfer pass emptied before.
#include "light_boxes.glsl"

layout(local_size_x = 64) in;

void main() {
    GpuLighting l = scene.lighting.lighting;
    uint i = gl_GlobalInvocationID.x;
    if (i >= l.light_box_count) return;
    uint slots = l.light_count;
    GpuAabb box;
    box.slot = NO_DECAL;
    box.owner = 0u;
    GpuLight light = scene.lights.lights[slots == 0u ? 0u : i % slots];
    vec3 at = light_position_finite(light) ? light.position : vec3(0.0);
    box.min = at;
    box.max = at;
    if (i < slots) {
        if (light_is_boxed(light)) {
            light_box(light, box.min, box.max);
            box.slot = i;
        } else if (light_is_unbounded(light)) {
            UnboundedLightsRef list = UnboundedLightsRef(l.unbounded_lights);
            list.slots[atomicAdd(list.count, 1u)] = i;
        }
    }
    LightBoxesRef(l.light_boxes).boxes[i] = box;
}
