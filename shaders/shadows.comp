#version 460
// The shadow pass on the ray-query tier (seed 001 §4.3, as the seed wrote it: a compute shader
// with ray queries). Masked materials' candidate hits run the alpha test before they count.
#extension GL_EXT_ray_query : require
#include "shadow_pass.glsl"
#include "alpha_mask.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

bool shadow_ray_unblocked(vec3 origin, vec3 dir, float tmin, float tmax) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsTerminateOnFirstHitEXT, 0xFF,
                          origin, tmin, dir, tmax);
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) == gl_RayQueryCandidateIntersectionTriangleEXT
            && alpha_mask_blocks(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false), rayQueryGetIntersectionPrimitiveIndexEXT(q, false),
                                 rayQueryGetIntersectionBarycentricsEXT(q, false))) {
            rayQueryConfirmIntersectionEXT(q);
        }
    }
    return rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionNoneEXT;
}

void main() {
    shadow_pixel(ivec2(gl_GlobalInvocationID.xy));
}
