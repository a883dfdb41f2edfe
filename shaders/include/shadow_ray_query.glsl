// A shadow ray as a ray query (the ray-query tier): opaque hits end it; candidate hits on
// masked and blended materials' instances (non-opaque in the scene TLAS) first ask
// `candidate_transmittance` whether they block, or filter the light and let it carry on. Used
// by the shadow pass (shadows.comp) and by ray-query lights, which trace their shadow rays
// inline while shading (ray_query_lights.glsl).
#ifndef SHADOW_RAY_QUERY_GLSL
#define SHADOW_RAY_QUERY_GLSL

#extension GL_EXT_ray_query : require
#include "scene.glsl"
#include "alpha_mask.glsl"

vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax) {
    rayQueryEXT q;
    rayQueryInitializeEXT(q, accelerationStructureEXT(scene.lighting.lighting.scene_tlas), gl_RayFlagsTerminateOnFirstHitEXT, 0xFF,
                          origin, tmin, dir, tmax);
    vec3 t = vec3(1.0);
    while (rayQueryProceedEXT(q)) {
        if (rayQueryGetIntersectionTypeEXT(q, false) != gl_RayQueryCandidateIntersectionTriangleEXT) continue;
        vec3 c = candidate_transmittance(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false),
                                         rayQueryGetIntersectionPrimitiveIndexEXT(q, false),
                                         rayQueryGetIntersectionBarycentricsEXT(q, false));
        t *= c;
        if (all(lessThan(t, vec3(SHADOW_OPAQUE_BELOW)))) rayQueryConfirmIntersectionEXT(q);
    }
    return rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionNoneEXT ? t : vec3(0.0);
}

#endif
