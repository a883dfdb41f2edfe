// Ray-query decals (seed 000 §4): the decal records, the containment test and texture lookup of
// one decal (§4.1.3), and the zero-length ray-query loop that enumerates every decal whose AABB
// holds the shaded point (§4.2.2, Listing 4.1).
//
// Gradients: derivatives do not exist inside the loop (non-uniform control flow), so callers
// take the world-position derivatives before it; each decal maps them into its own space and
// through its bilinear UV map to get textureGrad's UV gradients, so decals are mip-mapped.
//
// Normals: a decal's normal map is read in a tangent frame built at the surface from the
// decal's own axes (the gradients of decal-space x and y, projected onto the surface), so a
// rotated decal's normals rotate with it whatever the surface's UV layout.
//
// Decals on a skin (render/src/skinning, DECAL_ON_SKIN in their receivers) sit on a skinned
// instance's rest pose. A skinned surface is looked up twice: at its position for the decals of
// the world, and at its rest-pose position (decal_skin_view) for those on the skin, which then
// follow the skin exactly however it deforms. The rest→posed rotation of the surface's normal
// carries the decal's axes (and derivatives) between the two spaces.
#ifndef DECALS_GLSL
#define DECALS_GLSL

#include "scene.glsl"
#include "particles.glsl"
#include "blend.glsl"
#include "normals.glsl"

// GpuDecal, GpuDecalMaterial and the DECAL_* flags are in layout.glsl (render/src/layout.rs).
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer DecalsRef { GpuDecal decals[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer DecalMaterialsRef { GpuDecalMaterial decal_materials[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer DecalBoxesRef { GpuAabb boxes[]; };

// Place `i` of the particles' decal ring, kept in it (0 without a ring, whose address then names
// the lighting record): a load a compiler hoists out of its branch stays in bounds.
uint ring_place(uint i) {
    uint room = scene.lighting.lighting.decal_ring_room;
    return room == 0u ? 0u : min(i, room - 1u);
}

// The record of decal slot `slot`: the decal table's, or, for a decal a landing particle left
// (GPU_DECAL), the particles' decal ring's (render/src/particles).
GpuDecal decal_record(uint slot) {
    GpuLighting l = scene.lighting.lighting;
    if ((slot & GPU_DECAL) != 0u) return ParticleDecalsRef(l.decal_ring).decals[ring_place(slot & ~GPU_DECAL)];
    return DecalsRef(scene.decals).decals[slot];
}

// GpuDecal::material_channel: the material slot in the low DECAL_CHANNEL_SHIFT bits, the
// blending channel above them (render/src/scene/mod.rs, GpuDecal::pack_material_channel).
uint decal_material(GpuDecal d) { return d.material_channel & ((1u << DECAL_CHANNEL_SHIFT) - 1u); }
uint decal_channel(GpuDecal d) { return d.material_channel >> DECAL_CHANNEL_SHIFT; }

// The distance fade of decal `d` at `position`: 1 nearer the camera than its start, 0 beyond
// its end, linear between (the decal's own distances, or the camera's default when it has none).
float decal_distance_fade(GpuDecal d, vec3 position) {
    vec2 fade = d.distance_fade == 0u ? scene.camera.camera.decal_fade : unpackHalf2x16(d.distance_fade);
    if (fade == vec2(0.0)) return 1.0; // a camera record without a default
    float distance = length(position - scene.camera.camera.position);
    if (fade.y > fade.x) return clamp((fade.y - distance) / (fade.y - fade.x), 0.0, 1.0);
    return distance < fade.y ? 1.0 : 0.0;
}

// The decal slot of primitive `primitive` of instance `instance` of the decal structure
// `structure` (its instances' custom index): the scene's decal BLAS (0; one instance; its box
// table is dense, NO_DECAL for padding boxes) or the particles' decal ring's (1; instance k is
// the BLAS of the ring's places from k × decal_ring_segment on, render/src/particles/ring_accel.rs).
uint decal_of_box(uint structure, uint instance, uint primitive) {
    if (structure == 1u) {
        uint place = instance * scene.lighting.lighting.decal_ring_segment + primitive;
        return ParticleDecalBoxesRef(scene.lighting.lighting.decal_ring_boxes).boxes[ring_place(place)].slot;
    }
    return DecalBoxesRef(scene.decal_aabbs).boxes[primitive].slot;
}

// The particles' decal ring's TLAS (0: none), traced after the scene's decal TLAS.
uint64_t particle_decal_tlas() {
    return scene.lighting.lighting.decal_ring_tlas;
}

// Whether ray-traced decals have a structure to trace: the scene's or the particles' ring's.
bool decals_traced() {
    return scene.decal_tlas != 0ul || particle_decal_tlas() != 0ul;
}

// The surface as decals see it.
struct DecalSurface {
    vec3 position;
    vec3 dpdx;             // world-position derivatives, taken before the loop
    vec3 dpdy;
    vec3 geometric_normal; // for the angle fade
    vec3 normal;           // shading normal the decal normal maps are built on
    uint layers;           // receiver layers of the instance (| DECAL_ON_SKIN: the skin's view)
    vec4 skin_rotation;    // quaternion from the rest pose to the pose (identity in the world's view)
};

// Whether decal `d` lands on a surface of receiver `layers`: a shared layer, and a decal on a
// skin only in a skin's view, a world decal only in the world's.
bool decal_receives(GpuDecal d, uint layers) {
    return ((d.receivers ^ layers) & DECAL_ON_SKIN) == 0u && (d.receivers & layers & ~DECAL_ON_SKIN) != 0u;
}

vec3 quat_rotate(vec4 q, vec3 v) {
    return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v);
}

// The shortest rotation taking unit vector a to unit vector b.
vec4 quat_between(vec3 a, vec3 b) {
    float d = dot(a, b);
    if (d < -0.9999) return vec4(normalize(abs(a.x) < 0.9 ? cross(a, vec3(1.0, 0.0, 0.0)) : cross(a, vec3(0.0, 1.0, 0.0))), 0.0);
    return normalize(vec4(cross(a, b), 1.0 + d));
}

// The surface as the decals of the world see it: its own layers, no skin.
DecalSurface decal_world_view(vec3 position, vec3 dpdx, vec3 dpdy, vec3 geometric_normal, vec3 normal, uint layers) {
    return DecalSurface(position, dpdx, dpdy, geometric_normal, normal, layers & ~DECAL_ON_SKIN, vec4(0.0, 0.0, 0.0, 1.0));
}

// A skinned surface as the decals on its skin see it: at its rest-pose position (world space as
// the instance places its rest pose) with its rest-pose geometric normal, derivatives taken back
// to the rest pose by the rotation between the two normals.
DecalSurface decal_skin_view(DecalSurface s, vec3 rest_position, vec3 rest_normal) {
    vec4 q = quat_between(rest_normal, s.geometric_normal);
    vec4 back = vec4(-q.xyz, q.w);
    return DecalSurface(rest_position, quat_rotate(back, s.dpdx), quat_rotate(back, s.dpdy), rest_normal, s.normal,
                        s.layers | DECAL_ON_SKIN, q);
}

// The texture-free part of a decal's test (§4.1.3): the exact oriented-box test of `position`
// and the angle fade by the surface's geometric normal. False when the decal does not apply;
// else its local position and fade. (The ray-tracing pipeline's intersection shader runs this.)
bool decal_locate(GpuDecal d, vec3 position, vec3 geometric_normal, out vec3 local, out float fade) {
    local = (d.world_to_decal * vec4(position, 1.0)).xyz;
    fade = 0.0;
    if (any(greaterThan(abs(local), vec3(0.5)))) return false;   // outside the oriented box
    // Angle fade: the gradient of decal-space z is the projection axis (pointing back at the
    // projector); surfaces facing it have cos = 1.
    vec3 grad_z = vec3(d.world_to_decal[0][2], d.world_to_decal[1][2], d.world_to_decal[2][2]);
    float cos_angle = dot(geometric_normal, normalize(grad_z));
    vec2 angle = unpackHalf2x16(d.angle_fade);
    fade = clamp(cos_angle * angle.x + angle.y, 0.0, 1.0) * decal_distance_fade(d, position);
    return fade > 0.0;
}

// Samples a located decal's textures and accumulates it into its channel (Listing 4.2).
// (The ray-tracing pipeline's any-hit shader runs this.)
void decal_accumulate(inout DecalBlend b, GpuDecal d, vec3 local, float fade, DecalSurface s) {
    // Bilinear UVs over the four corners, and their derivatives along decal x and y.
    mat3 to_local = mat3(d.world_to_decal);
    // The decal's axes where the surface is (posed, for a decal on a skin).
    vec3 grad_x = quat_rotate(s.skin_rotation, vec3(d.world_to_decal[0][0], d.world_to_decal[1][0], d.world_to_decal[2][0]));
    vec3 grad_y = quat_rotate(s.skin_rotation, vec3(d.world_to_decal[0][1], d.world_to_decal[1][1], d.world_to_decal[2][1]));
    vec2 st = local.xy + 0.5;
    vec2 c0 = d.uv01.xy, c1 = d.uv01.zw, c2 = d.uv23.xy, c3 = d.uv23.zw;
    vec2 uv = mix(mix(c0, c1, st.x), mix(c3, c2, st.x), st.y);
    vec2 duv_ds = mix(c1 - c0, c2 - c3, st.y);
    vec2 duv_dt = mix(c3 - c0, c2 - c1, st.x);
    vec2 dlx = (to_local * s.dpdx).xy;
    vec2 dly = (to_local * s.dpdy).xy;
    vec2 duvdx = duv_ds * dlx.x + duv_dt * dlx.y;
    vec2 duvdy = duv_ds * dly.x + duv_dt * dly.y;

    GpuDecalMaterial m = DecalMaterialsRef(scene.decal_materials).decal_materials[decal_material(d)];
    vec4 texel = textureGrad(textures[nonuniformEXT(m.base_color_tex)], uv, duvdx, duvdy);
    float life = clamp(scene.camera.camera.time * d.life_scale + d.life_offset, 0.0, 1.0);
    float a = clamp(texel.a * m.base_color.a * d.opacity * fade * life, 0.0, 1.0);
    if (a <= 0.0) return;
    uint c = decal_channel(d);
    float w = d.weight;

    if ((m.flags & DECAL_ALBEDO) != 0u) blend_albedo(b, c, texel.rgb * m.base_color.rgb, a, w);
    if ((m.flags & DECAL_NORMAL) != 0u) {
        vec3 ts = decode_normal_texel(textureGrad(textures[nonuniformEXT(m.normal_tex)], uv, duvdx, duvdy).xyz);
        vec3 t = grad_x - s.normal * dot(s.normal, grad_x);
        float tl = dot(t, t);
        t = tl > 1e-12 ? t * inversesqrt(tl) : vec3(1.0, 0.0, 0.0);
        // Bitangent along decal +y (image up), right-handed with the surface normal.
        float sign_y = dot(cross(s.normal, t), grad_y) < 0.0 ? -1.0 : 1.0;
        vec3 n = perturb_normal(s.normal, vec4(t, sign_y), ts, m.normal_scale);
        blend_normal(b, c, n, a, w);
    }
    if ((m.flags & (DECAL_ROUGHNESS | DECAL_METALLIC)) != 0u) {
        vec2 mr = textureGrad(textures[nonuniformEXT(m.metallic_roughness_tex)], uv, duvdx, duvdy).bg;
        if ((m.flags & DECAL_ROUGHNESS) != 0u) blend_roughness(b, c, m.roughness * mr.y, a, w);
        if ((m.flags & DECAL_METALLIC) != 0u) blend_metallic(b, c, m.metallic * mr.x, a, w);
    }
    if ((m.flags & DECAL_EMISSIVE) != 0u) {
        vec3 glow = textureGrad(textures[nonuniformEXT(m.emissive_tex)], uv, duvdx, duvdy).rgb;
        blend_emissive(b, m.emissive * glow, a);
    }
}

// Tests decal record `d` against the surface and accumulates it into its channel; true when it
// applied (its receivers match, its box holds the point and its fade leaves something).
bool apply_decal_record(inout DecalBlend b, GpuDecal d, DecalSurface s) {
    if (!decal_receives(d, s.layers)) return false;
    vec3 local;
    float fade;
    if (!decal_locate(d, s.position, s.geometric_normal, local, fade)) return false;
    decal_accumulate(b, d, local, fade, s);
    return true;
}

// apply_decal_record for decal slot `index` (NO_DECAL: none).
bool apply_decal(inout DecalBlend b, uint index, DecalSurface s) {
    if (index == NO_DECAL) return false;
    return apply_decal_record(b, decal_record(index), s);
}

#if defined(RAY_QUERY_DECALS) || defined(DECALS_AT_HITS)
#extension GL_EXT_ray_query : require
#extension GL_EXT_control_flow_attributes : require

// Listing 4.1: a ray of length zero at the surface point; every AABB containing the point is a
// candidate, confirmed by apply_decal's box test. Returns the number of candidates (heat map).
// The scene's decals, then the particles' decal ring (each structure where there is one), in
// one traversal loop, kept a loop (one inlined query: lavapipe compiles each query site into the
// shader, and unrolled, the two would double the decal code it compiles).
// The structure (0: the scene's, 1: the ring's) is known here rather than asked of the query
// for the custom index; the ring's instance (its segment) is asked for. A fragment shader
// (FRAGMENT_SHADER defined before the includes) skips the queries in helper invocations:
// lavapipe 25.0 crashes reading a candidate's instance there, and decals take their texture
// gradients from their own UV map (textureGrad), not from neighbouring lanes.
uint gather_decals(inout DecalBlend b, DecalSurface s) {
    if (scene.decal_count == 0u) return 0u;
#ifdef FRAGMENT_SHADER
    if (gl_HelperInvocation) return 0u;
#endif
    uint tested = 0u;
    [[dont_unroll]] for (uint structure = 0u; structure < 2u; ++structure) {
        uint64_t tlas = structure == 0u ? scene.decal_tlas : particle_decal_tlas();
        if (tlas == 0ul) continue;
        rayQueryEXT query;
        rayQueryInitializeEXT(query, accelerationStructureEXT(tlas), gl_RayFlagsSkipClosestHitShaderEXT | gl_RayFlagsOpaqueEXT,
                              0xFF, s.position, 0.0, vec3(1.0, 0.0, 0.0), 0.0);
        while (rayQueryProceedEXT(query)) {
            tested += 1u;
            uint instance = structure == 0u ? 0u : uint(rayQueryGetIntersectionInstanceIdEXT(query, false));
            apply_decal(b, decal_of_box(structure, instance, uint(rayQueryGetIntersectionPrimitiveIndexEXT(query, false))), s);
        }
    }
    return tested;
}
#endif

#endif
