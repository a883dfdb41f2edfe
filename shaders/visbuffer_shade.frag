// variants: RAY_QUERY_DECALS
#version 460
// Visibility-buffer deferred texturing, shading pass (seed 000 §5.1.3). Each pixel fetches its
// triangle, intersects the camera ray through its centre with it to get barycentrics, and
// intersects the rays through the next pixel right and down with the same triangle's plane to
// get *analytic* derivatives of every attribute. The seed took texture gradients from the 2×2
// quad, which is wrong wherever a quad spans two triangles (its derivative bug); these gradients
// are per pixel, so mip selection is right at triangle edges too.
#include "scene.glsl"
#include "depth.glsl"
#include "material.glsl"
#include "shading.glsl"

layout(location = 0) out vec4 out_color;

// Barycentrics of the ray o + t·d on the plane of (a, b, c) (Möller–Trumbore without the
// inside test, so neighbouring pixels' rays may land outside the triangle).
vec3 barycentrics(vec3 o, vec3 d, vec3 a, vec3 b, vec3 c) {
    vec3 e1 = b - a;
    vec3 e2 = c - a;
    vec3 pv = cross(d, e2);
    float inv_det = 1.0 / dot(e1, pv);
    vec3 tv = o - a;
    float u = dot(tv, pv) * inv_det;
    float v = dot(d, cross(tv, e1)) * inv_det;
    return vec3(1.0 - u - v, u, v);
}

vec3 ray_dir(vec2 px) {
    return world_from_depth(px, 1.0) - scene.camera.camera.position; // through the near plane
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) discard; // sky: the clear colour stays
    uvec2 ids = texelFetch(visibility_ids, px, 0).rg;
    GpuInstance inst = scene.instances.instances[ids.x];
    GpuMaterial m = scene.materials.materials[inst.material];
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[inst.mesh];
    IndicesRef indices = IndicesRef(mesh.indices);
    VerticesRef vertices = VerticesRef(mesh.vertices);
    GpuVertex v0 = vertices.vertices[indices.indices[ids.y * 3u]];
    GpuVertex v1 = vertices.vertices[indices.indices[ids.y * 3u + 1u]];
    GpuVertex v2 = vertices.vertices[indices.indices[ids.y * 3u + 2u]];

    vec3 p0 = (inst.model * vec4(v0.position, 1.0)).xyz;
    vec3 p1 = (inst.model * vec4(v1.position, 1.0)).xyz;
    vec3 p2 = (inst.model * vec4(v2.position, 1.0)).xyz;
    vec3 eye = scene.camera.camera.position;
    vec3 dir = ray_dir(vec2(px));
    vec3 b = barycentrics(eye, dir, p0, p1, p2);
    vec3 bx = barycentrics(eye, ray_dir(vec2(px) + vec2(1.0, 0.0)), p0, p1, p2) - b;
    vec3 by = barycentrics(eye, ray_dir(vec2(px) + vec2(0.0, 1.0)), p0, p1, p2) - b;

    mat3x2 uvs = mat3x2(v0.uv, v1.uv, v2.uv);
    mat3 positions = mat3(p0, p1, p2);
    vec2 uv = uvs * b;
    MaterialSample ms = sample_material(m, uv, uvs * bx, uvs * by);

    mat3 normal_model = mat3(inst.normal_model);
    vec3 normal = normal_model * (mat3(v0.normal, v1.normal, v2.normal) * b);
    vec3 tangent = mat3(inst.model) * (mat3(v0.tangent.xyz, v1.tangent.xyz, v2.tangent.xyz) * b);
    vec3 geometric_n = safe_normalize(normal, vec3(0.0, 1.0, 0.0));
    // Front-facing as the rasteriser defines it: counter-clockwise on screen.
    bool front = dot(cross(p1 - p0, p2 - p0), dir) < 0.0;
    if ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && !front) geometric_n = -geometric_n;

    SurfaceInputs s;
    s.position = positions * b;
    s.dpdx = positions * bx;
    s.dpdy = positions * by;
    s.geometric_normal = geometric_n;
    s.normal = perturb_normal(geometric_n, vec4(tangent, v0.tangent.w), ms.tangent_normal, m.normal_scale);
    s.albedo = ms.base.rgb;
    s.roughness = ms.roughness;
    s.metallic = ms.metallic;
    s.occlusion = ms.occlusion;
    s.emissive = ms.emissive;
    s.decal_layers = inst.decal_layers;
    out_color = shade_surface(s);
}
