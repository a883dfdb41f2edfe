// Lights: point, spot and directional, and the area lights of area_lights.glsl, with a smooth
// window that reaches zero at the light's range (Frostbite §4.5; the range comes from eq. 4.1 of
// seed 001 when a light has none).
#ifndef LIGHTING_GLSL
#define LIGHTING_GLSL

#include "scene.glsl"
#include "brdf.glsl"
#include "normals.glsl"
#include "random.glsl"
#include "area_lights.glsl"

float distance_window(float dist2, float range) {
    float f = dist2 / (range * range);
    float s = clamp(1.0 - f * f, 0.0, 1.0);
    return s * s;
}

// The radiance `light` brings to point `p` from direction `l` (unit, towards the light), before
// any cosine: its colour by the distance window and the inverse square, and the spot's cone.
// An area light counts as a point at its centre of its area × its face's cosine, up to π
// (what weighs lights against each other, and lights particles; shade_light integrates its
// shape).
vec3 light_incidence(GpuLight light, vec3 p, out vec3 l) {
    if (light.kind == LIGHT_DIRECTIONAL) {
        l = -light.direction;
        return light.color;
    }
    vec3 to_light = light.position - p;
    float dist2 = dot(to_light, to_light);
    float inv_dist = inversesqrt(max(dist2, 1e-8));
    l = to_light * inv_dist;
    if (is_area_light(light)) {
        // The face's solid angle, at most a hemisphere's worth of cosine (π) right at the face.
        return light.color * distance_window(dist2, light.range)
            * min(area_of(light) * max(dot(light.direction, -l), 0.0) / max(dist2, 1e-8), PI);
    }
    // 1 / max(d², 10⁻⁴) from the reciprocal distance above, without a division of its own.
    float attenuation = distance_window(dist2, light.range) * (dist2 >= 1e-4 ? inv_dist * inv_dist : 1e4);
    if (light.kind == LIGHT_SPOT) {
        float cd = dot(light.direction, -l);
        float a = clamp(cd * light.spot_scale + light.spot_offset, 0.0, 1.0);
        attenuation *= a * a;
    }
    return light.color * attenuation;
}

// Radiance reflected towards v from one light of the kinds `areas` says: area lights (true) or
// the others (false); a light of the other kinds gives nothing. Called with a constant, it
// compiles to that kind's code alone, so that a loop over many lights can keep the area lights'
// larger code out of the pass over the punctual ones (shading.glsl's lists: the corridor's
// forward shading on the H200 took 16.3 ms so, 19.6 with both kinds in one loop).
vec3 shade_light_of(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v, bool areas) {
    if (areas) {
        if (!is_area_light(light)) return vec3(0.0);
        vec3 d = light.position - p;
        float window = distance_window(dot(d, d), light.range);
        return window > 0.0 && area_faces(light, p) ? area_light_brdf(light, s, p, n, v) * window : vec3(0.0);
    }
    if (is_area_light(light)) return vec3(0.0);
    vec3 l;
    vec3 incident = light_incidence(light, p, l);
    if (all(lessThanEqual(incident, vec3(0.0)))) return vec3(0.0);
    return brdf_cos(s, n, v, l) * incident;
}

// Radiance reflected towards v from one light, of any kind.
vec3 shade_light(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v) {
    return is_area_light(light) ? shade_light_of(light, s, p, n, v, true) : shade_light_of(light, s, p, n, v, false);
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
    if (is_area_light(light)) {
        tmax = area_ray_end(tmax);
        return area_faces(light, p);
    }
    return light.kind != LIGHT_SPOT || dot(light.direction, -dir) * light.spot_scale + light.spot_offset > 0.0;
}

// shadow_ray_towards aimed at a point of the light's shape (GpuLight::size), where temporal
// anti-aliasing averages frames (GpuCamera::taa_frame; without it a light has no size: a fixed
// dither would swim as the view moves): a direction uniform in the solid angle the light covers
// from `p`, chosen by `u` in [0, 1)²: the cone of the sphere (radius `size`) seen from p, or of
// the directional light's disc (angular radius atan(size)). Averaged over many `u`, the shadow
// rays' visibility is the share of the light p sees (each direction weighted alike, the cosine
// across the light's small cone ignored): the penumbra. A point inside the sphere sees it all.
// An area light's ray aims at a point spread uniformly over its face (each point of the face
// weighted alike).
bool shadow_ray_sampled(GpuLight light, vec3 p, vec2 u, out vec3 dir, out float tmax) {
    if (!shadow_ray_towards(light, p, dir, tmax)) return false;
    if (!(light.size > 0.0) || scene.camera.camera.taa_frame == 0u) return true;
    if (is_area_light(light)) {
        vec3 to = area_sample(light, u) - p;
        float d = length(to);
        dir = to / max(d, 1e-8);
        tmax = area_ray_end(d);
        return tmax > 0.0;
    }
    float cos_max;
    if (light.kind == LIGHT_DIRECTIONAL) {
        cos_max = inversesqrt(1.0 + light.size * light.size);
    } else {
        if (tmax <= light.size) {
            tmax = 1e-3;   // inside the light: nothing between (a ray as long as the shadow rays' tmin)
            return true;
        }
        float s = light.size / tmax;
        cos_max = sqrt(max(1.0 - s * s, 0.0));
    }
    float cos_t = 1.0 - u.x * (1.0 - cos_max);
    float sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    float phi = 6.28318531 * u.y;
    vec3 centre = dir;
    dir = tangent_frame(centre) * vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
    if (light.kind != LIGHT_DIRECTIONAL) {
        // To where the ray meets the sphere (its near side).
        float d = tmax, along = d * cos_t;
        tmax = along - sqrt(max(light.size * light.size - d * d * (1.0 - cos_t * cos_t), 0.0));
    }
    return true;
}

// The `u` of shadow_ray_sampled for pixel `px` and light slot `slot`: a hash of both and of
// temporal anti-aliasing's frame count, which never repeats, so that the history averages ever
// new points of the light.
vec2 shadow_sample(ivec2 px, uint slot) {
    uint seed = pcg_hash(uint(px.x) * 73856093u ^ uint(px.y) * 19349663u ^ slot * 83492791u
                         ^ pcg_hash(scene.camera.camera.taa_frame));
    float a = random01(seed);
    return vec2(a, random01(seed));
}

// The `u` of shadow_ray_sampled for a surface point `p` and light slot `slot`, for passes that
// know the point rather than the pixel (the ray-query lights): a hash of the point's bits, the
// light and temporal anti-aliasing's frame count.
vec2 shadow_sample_at(vec3 p, uint slot) {
    uvec3 b = floatBitsToUint(p);
    uint seed = pcg_hash(b.x ^ pcg_hash(b.y ^ pcg_hash(b.z ^ slot * 83492791u)) ^ pcg_hash(scene.camera.camera.taa_frame));
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
