// Cube-map texel directions, as Vulkan selects faces (spec. "Cube Map Face Selection"): face
// 0…5 = +X, −X, +Y, −Y, +Z, −Z; `uv` in [0, 1]² across the face, texel rows downwards. The
// environment's filtering passes write cube levels texel by texel through these directions.
#ifndef CUBEMAP_GLSL
#define CUBEMAP_GLSL

vec3 cube_direction(uint face, vec2 uv) {
    vec2 st = uv * 2.0 - 1.0;
    vec3 d;
    switch (face) {
        case 0u: d = vec3(1.0, -st.y, -st.x); break;
        case 1u: d = vec3(-1.0, -st.y, st.x); break;
        case 2u: d = vec3(st.x, 1.0, st.y); break;
        case 3u: d = vec3(st.x, -1.0, -st.y); break;
        case 4u: d = vec3(st.x, -st.y, 1.0); break;
        default: d = vec3(-st.x, -st.y, -1.0); break;
    }
    return normalize(d);
}

// The solid angle of texel `px` of a face `size` texels wide (Driscoll's closed form over the
// texel's corners).
float cube_texel_solid_angle(uvec2 px, uint size) {
    vec2 a = vec2(px) / float(size) * 2.0 - 1.0;
    vec2 b = vec2(px + 1u) / float(size) * 2.0 - 1.0;
    #define CUBE_AREA(x, y) atan((x) * (y), sqrt((x) * (x) + (y) * (y) + 1.0))
    return CUBE_AREA(a.x, a.y) - CUBE_AREA(a.x, b.y) - CUBE_AREA(b.x, a.y) + CUBE_AREA(b.x, b.y);
    #undef CUBE_AREA
}

#endif
