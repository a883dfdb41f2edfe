// A shadow ray as a ray query (the ray-query tier): the first hit ends it; candidate hits on
// alpha-masked materials' instances (non-opaque in the scene TLAS) run the mask test before they
// count. Used by the shadow pass (shadows.comp) and by ray-query lights, which trace their
// shadow rays inline while shading (ray_query_lights.glsl).
#ifndef SHADOW_RAY_QUERY_GLSL
#define SHADOW_RAY_QUERY_GLSL

#extension GL_EXT_ray_query : require
#include "scene.glsl"
#include "alpha_mask.glsl"

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

#endif
