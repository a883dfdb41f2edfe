// The surface a visibility-buffer pixel sees (seed 000 §3.4.1, §5.1.3): its triangle is fetched
// by the ids the visibility pass wrote, the camera ray through the pixel's centre is intersected
// with it for barycentrics, and the rays through the next pixel right and down with the same
// triangle's plane give *analytic* derivatives of every attribute. The seed took texture
// gradients from the 2×2 quad, which is wrong wherever a quad spans two triangles (its
// derivative bug); these gradients are per pixel, so mip selection is right at triangle edges
// too. The visibility-buffer shading pass and the decal pass (for the forward and
// visibility-buffer pipelines) both read surfaces through this.
#ifndef VISIBILITY_GLSL
#define VISIBILITY_GLSL

#include "scene.glsl"
#include "depth.glsl"
#include "normals.glsl"

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

struct VisibleSurface {
    GpuInstance instance;
    GpuMaterial material;
    vec3 position;
    vec3 dpdx;               // analytic world-position derivatives
    vec3 dpdy;
    vec3 geometric_normal;   // interpolated vertex normal, facing the viewer on double-sided materials
    vec4 tangent;            // world tangent and bitangent sign
    vec2 uv;
    vec2 duvdx;
    vec2 duvdy;
};

VisibleSurface visible_surface(ivec2 px, uvec2 ids) {
    VisibleSurface v;
    v.instance = scene.instances.instances[ids.x];
    v.material = scene.materials.materials[v.instance.material];
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[v.instance.mesh];
    IndicesRef indices = IndicesRef(mesh.indices);
    VerticesRef vertices = VerticesRef(mesh.vertices);
    GpuVertex v0 = vertices.vertices[indices.indices[ids.y * 3u]];
    GpuVertex v1 = vertices.vertices[indices.indices[ids.y * 3u + 1u]];
    GpuVertex v2 = vertices.vertices[indices.indices[ids.y * 3u + 2u]];

    mat4 model = v.instance.model;
    vec3 p0 = (model * vec4(v0.position, 1.0)).xyz;
    vec3 p1 = (model * vec4(v1.position, 1.0)).xyz;
    vec3 p2 = (model * vec4(v2.position, 1.0)).xyz;
    vec3 eye = scene.camera.camera.position;
    vec3 dir = ray_dir(vec2(px));
    vec3 b = barycentrics(eye, dir, p0, p1, p2);
    vec3 bx = barycentrics(eye, ray_dir(vec2(px) + vec2(1.0, 0.0)), p0, p1, p2) - b;
    vec3 by = barycentrics(eye, ray_dir(vec2(px) + vec2(0.0, 1.0)), p0, p1, p2) - b;

    mat3x2 uvs = mat3x2(v0.uv, v1.uv, v2.uv);
    mat3 positions = mat3(p0, p1, p2);
    v.uv = uvs * b;
    v.duvdx = uvs * bx;
    v.duvdy = uvs * by;
    v.position = positions * b;
    v.dpdx = positions * bx;
    v.dpdy = positions * by;

    vec3 normal = mat3(v.instance.normal_model) * (mat3(v0.normal, v1.normal, v2.normal) * b);
    v.tangent = vec4(mat3(model) * (mat3(v0.tangent.xyz, v1.tangent.xyz, v2.tangent.xyz) * b), v0.tangent.w);
    v.geometric_normal = safe_normalize(normal, vec3(0.0, 1.0, 0.0));
    // Front-facing as the rasteriser defines it: counter-clockwise on screen.
    bool front = dot(cross(p1 - p0, p2 - p0), dir) < 0.0;
    if ((v.material.flags & MATERIAL_DOUBLE_SIDED) != 0u && !front) v.geometric_normal = -v.geometric_normal;
    return v;
}

#endif
