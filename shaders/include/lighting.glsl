// Punctual lights: point, spot and directional, with a smooth window that reaches zero at the
// light's range (Frostbite §4.5; the range comes from eq. 4.1 of seed 001 when a light has none).
#ifndef LIGHTING_GLSL
#define LIGHTING_GLSL

#include "scene.glsl"
#include "brdf.glsl"
#include "normals.glsl"
#include "random.glsl"

float distance_window(float dist2, float range) {
    float f = dist2 / (range * range);
    float s = clamp(1.0 - f * f, 0.0, 1.0);
    return s * s;
}

// The radiance `light` brings to point `p` from direction `l` (unit, towards the light), before
// any cosine: its colour by the distance window and the inverse square, and the spot's cone.
vec3 light_incidence(GpuLight light, vec3 p, out vec3 l) {
    if (light.kind == LIGHT_DIRECTIONAL) {
        l = -light.direction;
        return light.color;
    }
    vec3 to_light = light.position - p;
    float dist2 = dot(to_light, to_light);
    l = to_light * inversesqrt(max(dist2, 1e-8));
    float attenuation = distance_window(dist2, light.range) / max(dist2, 1e-4);
    if (light.kind == LIGHT_SPOT) {
        float cd = dot(light.direction, -l);
        float a = clamp(cd * light.spot_scale + light.spot_offset, 0.0, 1.0);
        attenuation *= a * a;
    }
    return light.color * attenuation;
}

// Radiance reflected towards v from one light.
vec3 shade_light(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v) {
    vec3 l;
    vec3 incident = light_incidence(light, p, l);
    if (all(lessThanEqual(incident, vec3(0.0)))) return vec3(0.0);
    return brdf_cos(s, n, v, l) * incident;
}

// The direction to `light` from `p` and the ray's length; false when the light cannot reach p.
bool shadow_ray_towards(GpuLight light, vec3 p, out vec3 dir, out float tmax) {
    dir = vec3(0.0);
    tmax = 0.0;
    if (light.kind == LIGHT_NONE) return false;
    if (light.kind == LIGHT_DIRECTIONAL) {
        dir = -light.direction;
        tmax = 1000.0;
        return true;
    }
    vec3 to = light.position - p;
    float d2 = dot(to, to);
    if (!(d2 < light.range * light.range) || d2 < 1e-12) return false;
    float d = sqrt(d2);
    dir = to / d;
    tmax = d;
    return light.kind != LIGHT_SPOT || dot(light.direction, -dir) * light.spot_scale + light.spot_offset > 0.0;
}

// shadow_ray_towards aimed at a point of the light's shape (GpuLight::size): a uniform point,
// chosen by `u` in [0, 1)², of the disc that faces `p`: the sphere's silhouette (radius `size`,
// through the light's position) or the directional light's disc (angular radius atan(size)).
// Averaged over many `u`, the shadow rays' visibility is the fraction of the light a point sees:
// the penumbra. A light of size 0 is the point shadow_ray_towards aims at.
bool shadow_ray_sampled(GpuLight light, vec3 p, vec2 u, out vec3 dir, out float tmax) {
    if (!shadow_ray_towards(light, p, dir, tmax)) return false;
    if (!(light.size > 0.0)) return true;
    mat3 frame = tangent_frame(dir);
    float r = sqrt(u.x), phi = 6.28318531 * u.y;
    vec3 offset = light.size * r * (frame[0] * cos(phi) + frame[1] * sin(phi));
    if (light.kind == LIGHT_DIRECTIONAL) {
        dir = normalize(dir + offset);
        return true;
    }
    vec3 to = dir * tmax + offset;
    tmax = length(to);
    dir = to / tmax;
    return true;
}

// The `u` of shadow_ray_sampled for pixel `px` and light slot `slot`: a hash of both and of
// temporal anti-aliasing's jitter, which moves every frame, so that the accumulated history
// averages many points of the light (without temporal anti-aliasing a pixel keeps its point:
// the penumbra is a fixed dither).
vec2 shadow_sample(ivec2 px, uint slot) {
    vec2 jitter = scene.camera.camera.jitter;
    uint seed = pcg_hash(uint(px.x) * 73856093u ^ uint(px.y) * 19349663u ^ slot * 83492791u
                         ^ pcg_hash(floatBitsToUint(jitter.x) ^ (floatBitsToUint(jitter.y) * 2654435761u)));
    float a = random01(seed);
    return vec2(a, random01(seed));
}

// A shadow ray's origin for surface point `p` with normal `n` (facing the camera): lifted along
// n by 0.1 % of its distance to the camera, so that depth quantisation cannot put it under its
// own surface.
vec3 shadow_origin(vec3 p, vec3 n) {
    return p + n * (1e-3 * length(scene.camera.camera.position - p));
}

// The origin of a ray that leaves a rasterised surface for the scene's acceleration structure:
// lifted as `shadow_origin` does, and by the world size of the level-of-detail limit there
// (lod_lift, per metre of distance), so that a coarser level, which lies up to that far inside
// the full mesh the rays trace, cannot shadow or reflect itself (render/src/lod). Rays from a
// point the rays themselves found (a reflection's hit) lie on the full mesh and need no more
// than `shadow_origin`.
vec3 raster_origin(vec3 p, vec3 n) {
    return p + n * ((1e-3 + scene.lighting.lighting.lod_lift) * length(scene.camera.camera.position - p));
}

#endif
