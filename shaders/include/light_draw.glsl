// Stochastic direct lighting where shading finds a pixel's lights itself (ray-query lights, on
// both ray-tracing tiers: ray_query_lights.glsl walks them with a ray query, ray_pipeline_lights.glsl
// gets them from a traced ray's any-hit shader). The lights to draw from are shaded unshadowed
// into a sum, and one of them is drawn in proportion to the luminance of its light (weighted
// reservoir sampling, as direct_sampling.glsl draws from a list, one uniform number a light,
// in any order); the sum is then multiplied by what one shadow ray to the drawn light lets
// through (the ratio estimator of Heitz et al. 2018, a pixel's own: no denoiser runs between
// the ray and shading). What is unshadowed stays exact; what is shadowed is right on average
// (in luminance), noise that temporal anti-aliasing averages. The material is at hand while
// shading, so the draw follows the whole BRDF, specular lobe included.
#ifndef LIGHT_DRAW_GLSL
#define LIGHT_DRAW_GLSL

#include "color.glsl"
#include "random.glsl"
#include "lighting.glsl"

const uint NO_DRAWN_LIGHT = 0xFFFFFFFFu;

// The lights drawn from so far: their unshadowed light summed, their luminances summed, the
// slot drawn in proportion, and the draw's random state.
struct LightDraw {
    vec3 unshadowed;
    float total;
    uint slot;
    uint seed;
};

// An empty draw for surface point `p`: its numbers a hash of the point and temporal
// anti-aliasing's frame count (so they change every frame under it and stay put without it),
// apart from the points on lights (shadow_sample_at).
LightDraw light_draw_start(vec3 p) {
    uvec3 b = floatBitsToUint(p);
    return LightDraw(vec3(0.0), 0.0, NO_DRAWN_LIGHT, pcg_hash(b.x ^ pcg_hash(b.y ^ pcg_hash(b.z ^ 0x68E31DA4u)) ^ pcg_hash(~scene.camera.camera.taa_frame)));
}

// Offers the light in `slot`, whose unshadowed radiance at the surface is `c`, to the draw.
void light_draw_offer(inout LightDraw d, uint slot, vec3 c) {
    float w = luminance(c);
    if (!(w > 0.0)) return;
    d.unshadowed += c;
    d.total += w;
    if (random01(d.seed) * d.total <= w) d.slot = slot;
}

#ifndef LIGHT_DRAW_OFFER_ONLY
// What a shadow ray from `origin` along `dir` lets through (0: blocked), defined by the
// including shader: a ray query (shadow_ray_query.glsl) or a traced ray (ray_pipeline_lights.glsl).
vec3 shadow_ray_transmittance(vec3 origin, vec3 dir, float tmin, float tmax);

// Where a shadow ray leaves surface point `p` (facing the camera along `n`): from a rasterised
// surface lifted by the level-of-detail limit too (raster_origin), from a reflection's hit,
// which lies on the full mesh the rays trace, by shadow_origin alone.
vec3 light_ray_origin(vec3 p, vec3 n) {
#ifdef REFLECTION_RAY_QUERY
    return shadow_origin(p, n);
#else
    return raster_origin(p, n);
#endif
}

// `c`, the radiance of `light` (in `slot`) at surface point `p`, through its shadow ray: zero
// when blocked or culled (the surface, facing the camera along `facing`, its geometric normal,
// faces away), filtered by the glass it crossed. The ray aims at a point of the light's shape
// (soft shadows where it has a size, as the shadow pass does), chosen by a hash of the point.
vec3 shadowed_by_ray(GpuLight light, uint slot, vec3 c, vec3 p, vec3 facing, bool cull) {
    if (all(equal(c, vec3(0.0)))) return c;
    vec3 dir;
    float tmax;
    if (!shadow_ray_sampled(light, p, shadow_sample_at(p, slot), dir, tmax)) return vec3(0.0);
    if (cull && dot(facing, dir) <= 0.0) return vec3(0.0);
    return c * shadow_ray_transmittance(light_ray_origin(p, facing), dir, 1e-3, tmax);
}

// The drawn lights' light at `p`: their unshadowed sum through one shadow ray to the drawn one.
vec3 light_draw_resolve(LightDraw d, vec3 p, vec3 facing, bool cull) {
    if (d.slot == NO_DRAWN_LIGHT) return vec3(0.0);
    return shadowed_by_ray(scene.lights.lights[d.slot], d.slot, d.unshadowed, p, facing, cull);
}
#endif

#endif
