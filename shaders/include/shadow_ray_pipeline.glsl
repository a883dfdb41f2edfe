// A shadow ray as a traceRayEXT (the ray-tracing-pipeline tier, the lent GPUs having no ray
// queries): it skips closest-hit shaders and ends at the first hit that blocks it; the miss
// shader (shadows.rmiss) marks the ray unblocked, and masked and blended materials' hits run
// the any-hit shader (shadows.rahit), which filters the light through glass. Used by the shadow
// pass (shadows.rgen) and the ambient occlusion's rays (occlusion.rgen), whose pipelines put
// those shaders at miss index 0 and hit group 0, and by the ray-query lights' drawn shadows
// (ray_pipeline_lights.glsl), which put them at SHADOW_SBT_INDEX with the payload at
// SHADOW_PAYLOAD_LOCATION.
#ifndef SHADOW_RAY_PIPELINE_GLSL
#define SHADOW_RAY_PIPELINE_GLSL

#extension GL_EXT_ray_tracing : require
#include "scene.glsl"

#ifndef SHADOW_SBT_INDEX
#define SHADOW_SBT_INDEX 0
#define SHADOW_PAYLOAD_LOCATION 0
#endif
layout(location = SHADOW_PAYLOAD_LOCATION) rayPayloadEXT vec4 shadow_payload;

vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax) {
    shadow_payload = vec4(1.0, 1.0, 1.0, 0.0);
    traceRayEXT(accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsTerminateOnFirstHitEXT | gl_RayFlagsSkipClosestHitShaderEXT,
                0xFF, SHADOW_SBT_INDEX, 0, SHADOW_SBT_INDEX, origin, tmin, dir, tmax, SHADOW_PAYLOAD_LOCATION);
    return shadow_payload.w != 0.0 ? shadow_payload.rgb : vec3(0.0);
}

#endif
