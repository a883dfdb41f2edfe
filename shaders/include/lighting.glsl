// Punctual lights: point, spot and directional, with a smooth window that reaches zero at the
// light's range (Frostbite §4.5; the range comes from eq. 4.1 of seed 001 when a light has none).
#ifndef LIGHTING_GLSL
#define LIGHTING_GLSL

#include "scene.glsl"
#include "brdf.glsl"

float distance_window(float dist2, float range) {
    float f = dist2 / (range * range);
    float s = clamp(1.0 - f * f, 0.0, 1.0);
    return s * s;
}

// Radiance reflected towards v from one light.
vec3 shade_light(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v) {
    vec3 l;
    float attenuation;
    if (light.kind == LIGHT_DIRECTIONAL) {
        l = -light.direction;
        attenuation = 1.0;
    } else {
        vec3 to_light = light.position - p;
        float dist2 = dot(to_light, to_light);
        l = to_light * inversesqrt(max(dist2, 1e-8));
        attenuation = distance_window(dist2, light.range) / max(dist2, 1e-4);
        if (light.kind == LIGHT_SPOT) {
            float cd = dot(light.direction, -l);
            float a = clamp(cd * light.spot_scale + light.spot_offset, 0.0, 1.0);
            attenuation *= a * a;
        }
    }
    if (attenuation <= 0.0) return vec3(0.0);
    return brdf_cos(s, n, v, l) * light.color * attenuation;
}

#endif
