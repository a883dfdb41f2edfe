// Motion vectors (render/src/motion): what one texel of the motion image holds, and the movers
// the raster pass draws over the camera's motion.
//   xy  this frame's screen position less the previous frame's, in UV units (both unjittered;
//       v grows downwards, as rows do: the viewport is flipped, so NDC y grows upwards)
//   z   the surface's view depth in the previous frame
//   w   its view depth in this frame (MOTION_FAR where nothing was drawn)
#ifndef MOTION_GLSL
#define MOTION_GLSL

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MoversRef { GpuMover movers[]; };
// A posed mesh's previous positions, a vec4 per vertex behind its vertices (shaders/skinning.comp).
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer PreviousPositionsRef { vec4 positions[]; };

// Depth stored for the sky, and the most any depth is stored as (RGBA16F holds up to 65504).
const float MOTION_FAR = 60000.0;

// The motion record of a point whose clip positions are `now` (unjittered) and `before`,
// at view depths `depth_now` and `depth_before`.
vec4 motion_record(vec4 now, vec4 before, float depth_now, float depth_before) {
    vec2 motion = (now.xy / now.w - before.xy / before.w) * vec2(0.5, -0.5);
    return vec4(motion, min(depth_before, MOTION_FAR), min(depth_now, MOTION_FAR));
}

#endif
