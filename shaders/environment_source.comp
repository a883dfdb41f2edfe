#version 460
// The environment's radiance cube, level 0 (render/src/environment): the procedural sky, a
// uniform radiance, or an equirectangular HDR map (bilinear: longitude wraps, rows clamp; row 0
// looks up, the centre column along +X, longitude increasing towards +Z).
#include "environment_levels.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
#include "sky.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer TexelsRef { float texels[]; };

vec3 map_texel(GpuEnvironmentJob env, ivec2 p) {
    ivec2 size = ivec2(env.source_size[0], env.source_size[1]);
    p = ivec2((p.x % size.x + size.x) % size.x, clamp(p.y, 0, size.y - 1));
    uint i = 3u * (uint(p.y) * uint(size.x) + uint(p.x));
    TexelsRef t = TexelsRef(env.source);
    return vec3(t.texels[i], t.texels[i + 1u], t.texels[i + 2u]);
}

vec3 map_radiance(GpuEnvironmentJob env, vec3 d) {
    vec2 size = vec2(env.source_size[0], env.source_size[1]);
    vec2 uv = vec2(atan(d.z, d.x) / (2.0 * PI) + 0.5, acos(clamp(d.y, -1.0, 1.0)) / PI);
    vec2 p = uv * size - 0.5;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - vec2(i);
    return mix(mix(map_texel(env, i), map_texel(env, i + ivec2(1, 0)), f.x),
               mix(map_texel(env, i + ivec2(0, 1)), map_texel(env, i + ivec2(1, 1)), f.x), f.y);
}

void main() {
    GpuEnvironmentJob env = environment_job();
    uvec3 texel;
    vec3 d;
    if (!level_texel(env.face, texel, d)) return;
    vec3 radiance;
    if (env.mode == ENVIRONMENT_MAP) radiance = map_radiance(env, d);
    else if (env.mode == ENVIRONMENT_UNIFORM) radiance = env.color.rgb;
    else radiance = sky_radiance(d, env.sun.xyz, env.sun_color.rgb);
    // Half floats end at 65504: a brighter texel (an HDR map's sun) is clamped there.
    imageStore(environment_levels[0], ivec3(texel), vec4(min(radiance, vec3(65504.0)), 1.0));
}
