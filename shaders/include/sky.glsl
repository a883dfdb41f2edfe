// The procedural sky (render/src/environment): what lights the scene and is drawn behind it when
// no environment map is given. A cheap analytic model, not a simulation: a zenith-to-horizon
// gradient with Rayleigh's (1 + cos²γ) brightening around the sun and a Mie-like glow towards it
// (γ the angle to the sun), dimmed as the sun sets, over a grey ground the sun lights. Its scale
// follows the sun's illuminance (the scene's brightest directional light), so a sky looks right
// whatever units the scene's lights use: the sky gives a horizontal surface about a seventh of
// what a high sun does. The sun's disc is not in it (the directional light is the sun); the sky
// pass draws the disc.
#ifndef SKY_GLSL
#define SKY_GLSL

#include "color.glsl"
#include "brdf.glsl"

const vec3 SKY_ZENITH = vec3(0.16, 0.30, 0.62);
const vec3 SKY_HORIZON = vec3(0.55, 0.62, 0.72);
const float SKY_SCALE = 0.12;         // radiance per lux of sun, at the gradient's colours
const float GROUND_ALBEDO = 0.25;

vec3 sky_radiance(vec3 d, vec3 sun, vec3 sun_illuminance) {
    float e = max(luminance(sun_illuminance), 1e-6);
    vec3 tint = sun_illuminance / e;
    float day = smoothstep(-0.12, 0.15, sun.y);
    float cos_gamma = dot(d, sun);
    float h = max(d.y, 0.0);
    vec3 gradient = mix(SKY_HORIZON, SKY_ZENITH, sqrt(h));
    float rayleigh = 0.75 * (1.0 + cos_gamma * cos_gamma);
    float mie = 0.8 * pow(max(cos_gamma, 0.0), 16.0) / (1.0 + 4.0 * h);
    vec3 sky = (gradient * rayleigh + tint * vec3(1.0, 0.86, 0.65) * mie) * (e * SKY_SCALE * day);
    // The ground: lit by the sun and by the sky above it, blending into the horizon over the
    // first degrees below it.
    vec3 ground = GROUND_ALBEDO / PI * (sun_illuminance * max(sun.y, 0.0) + SKY_HORIZON * (e * SKY_SCALE * day * PI));
    return d.y >= 0.0 ? sky : mix(ground, sky, exp(d.y * 40.0));
}

#endif
