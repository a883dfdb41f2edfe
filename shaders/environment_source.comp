#version 460
// The environment's radiance cube, level 0 (render/src/environment): the procedural sky, a
// uniform radiance, an equirectangular HDR map (bilinear: longitude wraps, rows clamp; row 0
// looks up, the centre column along +X, longitude increasing towards +Z), or a cube map's six
// faces stacked in one image (+X, −X, +Y, −Y, +Z, −Z, as KTX2 stores them; bilinear within the
// face the direction selects, clamped at its edges).
#include "environment_levels.glsl"
#include "storable.glsl"

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

// The cube map's face selected by `d` and the texel coordinates there (Vulkan's face selection
// and orientation, as cubemap.glsl writes our own cubes).
vec3 cube_map_radiance(GpuEnvironmentJob env, vec3 d) {
    vec3 a = abs(d);
    uint face;
    vec2 st;
    float ma;
    if (a.x >= a.y && a.x >= a.z) { face = d.x > 0.0 ? 0u : 1u; ma = a.x; st = vec2(d.x > 0.0 ? -d.z : d.z, -d.y); }
    else if (a.y >= a.z) { face = d.y > 0.0 ? 2u : 3u; ma = a.y; st = vec2(d.x, d.y > 0.0 ? d.z : -d.z); }
    else { face = d.z > 0.0 ? 4u : 5u; ma = a.z; st = vec2(d.z > 0.0 ? d.x : -d.x, -d.y); }
    int size = int(env.source_size[0]);
    vec2 p = (st / ma * 0.5 + 0.5) * float(size) - 0.5;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - vec2(i);
    ivec2 row = ivec2(0, int(face) * size);
    #define CUBE_TEXEL(q) map_texel(env, row + clamp(q, ivec2(0), ivec2(size - 1)))
    return mix(mix(CUBE_TEXEL(i), CUBE_TEXEL(i + ivec2(1, 0)), f.x), mix(CUBE_TEXEL(i + ivec2(0, 1)), CUBE_TEXEL(i + ivec2(1, 1)), f.x), f.y);
    #undef CUBE_TEXEL
}

void main() {
    GpuEnvironmentJob env = environment_job();
    uvec3 texel;
    vec3 d;
    if (!level_texel(env.face, texel, d)) return;
    vec3 radiance;
    if (env.mode == ENVIRONMENT_MAP) radiance = map_radiance(env, d);
    else if (env.mode == ENVIRONMENT_CUBE_MAP) radiance = cube_map_radiance(env, d);
    else if (env.mode == ENVIRONMENT_UNIFORM) radiance = env.color.rgb;
    else radiance = sky_radiance(d, env.sun.xyz, env.sun_color.rgb);
    // Half floats end at 65504: a brighter texel (an HDR map's sun) is clamped there, and what is
    // not a radiance (NaN, negative) is none, so the filtered levels never hold a non-finite value.
    imageStore(environment_levels[0], ivec3(texel), vec4(max(storable_radiance(radiance), vec3(0.0)), 1.0));
}
