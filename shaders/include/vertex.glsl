// Compact vertices (render/src/scene/vertex.rs): octahedral normals and tangents in two snorm16
// (the tangent's bitangent sign in bit 0), UVs in two unorm16 over the mesh's UV range. The
// packing matches the CPU's; the skinning pass packs its posed vertices with these functions.
#ifndef VERTEX_GLSL
#define VERTEX_GLSL

// The unit vector a point of the octahedron's square stands for.
vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.x += n.x >= 0.0 ? -t : t;
    n.y += n.y >= 0.0 ? -t : t;
    return normalize(n);
}

// A unit vector on the octahedron's square, in [-1, 1]² (a zero vector gives straight up).
vec2 oct_encode(vec3 n) {
    float l1 = abs(n.x) + abs(n.y) + abs(n.z);
    if (!(l1 > 0.0)) return vec2(0.0);
    n /= l1;
    if (n.z >= 0.0) return n.xy;
    return (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
}

vec3 unpack_normal(uint packed) {
    return oct_decode(unpackSnorm2x16(packed));
}

vec4 unpack_tangent(uint packed) {
    return vec4(oct_decode(unpackSnorm2x16(packed & ~1u)), (packed & 1u) != 0u ? -1.0 : 1.0);
}

uint pack_normal(vec3 n) {
    return packSnorm2x16(oct_encode(n));
}

uint pack_tangent(vec4 t) {
    return (packSnorm2x16(oct_encode(t.xyz)) & ~1u) | (t.w < 0.0 ? 1u : 0u);
}

// Where a posed mesh's previous positions (a vec4 a vertex) start: after its vertices, on the
// next 16 bytes (an odd number of 24-byte vertices ends 8 bytes short of it);
// `previous_positions_offset` in render/src/scene/vertex.rs.
uint64_t previous_positions(uint64_t vertices, uint vertex_count) {
    return vertices + ((uint64_t(vertex_count) * uint64_t(VERTEX_BYTES) + 15ul) & ~15ul);
}

// A vertex's UV: the mesh's UV range applied to its two unorm16.
vec2 unpack_uv(uint packed, GpuMeshInfo mesh) {
    return mesh.uv_offset + unpackUnorm2x16(packed) * mesh.uv_scale;
}

#endif
