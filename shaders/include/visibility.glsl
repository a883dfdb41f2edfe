// The surface a visibility-buffer pixel sees (seed 000 §3.4.1, §5.1.3): its triangle is fetched
// by the ids the visibility pass wrote, the camera ray through the pixel (its centre; MSAA's sample
// 0, where the resolved depth and ids were taken, through the camera record's inverse) is intersected
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
    bool skinned;            // a posed mesh: the rest pose below is where decals on its skin are
    vec3 rest_position;      // rest-pose position and geometric normal, placed by the instance
    vec3 rest_normal;
};

// The rest pose of the point with barycentrics `b` on triangle `triangle` of a posed mesh
// (render/src/skinning): its position and normal as `instance` places them, the normal turned
// to agree with `facing` where the posed vertex normals `posed_normal` disagree with it.
void rest_pose_at(GpuInstance instance, GpuMeshInfo mesh, uint triangle, vec3 b, vec3 posed_normal, vec3 facing,
                  out vec3 position, out vec3 normal) {
    IndicesRef indices = IndicesRef(mesh.indices);
    VerticesRef rest = VerticesRef(mesh.rest);
    GpuVertex r0 = rest.vertices[indices.indices[triangle * 3u]];
    GpuVertex r1 = rest.vertices[indices.indices[triangle * 3u + 1u]];
    GpuVertex r2 = rest.vertices[indices.indices[triangle * 3u + 2u]];
    position = (instance.model * vec4(mat3(r0.position, r1.position, r2.position) * b, 1.0)).xyz;
    mat3 normals = mat3(unpack_normal(r0.normal), unpack_normal(r1.normal), unpack_normal(r2.normal));
    normal = safe_normalize(mat3(instance.normal_model) * (normals * b), vec3(0.0, 1.0, 0.0));
    if (dot(posed_normal, facing) < 0.0) normal = -normal;
}

// A triangle of an instance, fetched: its vertices and their world positions.
struct InstanceTriangle {
    GpuInstance instance;
    GpuMeshInfo mesh;
    uint index;              // the triangle's index in the mesh
    GpuVertex v0, v1, v2;
    vec3 p0, p1, p2;         // world positions
};

InstanceTriangle instance_triangle(uint instance, uint triangle) {
    InstanceTriangle t;
    t.instance = scene.instances.instances[instance];
    t.mesh = MeshesRef(scene.meshes).meshes[t.instance.mesh];
    t.index = triangle;
    IndicesRef indices = IndicesRef(t.mesh.indices);
    VerticesRef vertices = VerticesRef(t.mesh.vertices);
    t.v0 = vertices.vertices[indices.indices[triangle * 3u]];
    t.v1 = vertices.vertices[indices.indices[triangle * 3u + 1u]];
    t.v2 = vertices.vertices[indices.indices[triangle * 3u + 2u]];
    mat4 model = t.instance.model;
    t.p0 = (model * vec4(t.v0.position, 1.0)).xyz;
    t.p1 = (model * vec4(t.v1.position, 1.0)).xyz;
    t.p2 = (model * vec4(t.v2.position, 1.0)).xyz;
    return t;
}

// The rest pose of what pixel `px` sees of triangle `triangle` of instance slot `instance`, for
// pipelines that keep only those ids (the deferred G-buffer): the camera ray through the pixel's
// centre against the posed triangle gives the barycentrics. False for a mesh that is not posed.
bool rest_pose_of_pixel(ivec2 px, uint instance, uint triangle, vec3 facing, out vec3 position, out vec3 normal) {
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[scene.instances.instances[instance].mesh];
    if (mesh.rest == mesh.vertices || mesh.index_count == 0u) return false;
    InstanceTriangle t = instance_triangle(instance, triangle);
    vec3 b = barycentrics(scene.camera.camera.position, ray_dir(vec2(px)), t.p0, t.p1, t.p2);
    vec3 posed_normal = mat3(t.instance.normal_model) * (mat3(unpack_normal(t.v0.normal), unpack_normal(t.v1.normal), unpack_normal(t.v2.normal)) * b);
    rest_pose_at(t.instance, t.mesh, triangle, b, posed_normal, facing, position, normal);
    return true;
}

// The surface of triangle `t` at barycentrics `b`, seen along `dir`, with `bx` and `by` the
// barycentrics' changes over one footprint step in each screen direction (the pixel's
// neighbours for the camera, a ray cone's width at a reflection ray's hit).
VisibleSurface triangle_surface(InstanceTriangle t, vec3 b, vec3 bx, vec3 by, vec3 dir) {
    VisibleSurface v;
    v.instance = t.instance;
    v.material = scene.materials.materials[t.instance.material];
    mat3x2 uvs = mat3x2(unpack_uv(t.v0.uv, t.mesh), unpack_uv(t.v1.uv, t.mesh), unpack_uv(t.v2.uv, t.mesh));
    mat3 positions = mat3(t.p0, t.p1, t.p2);
    v.uv = uvs * b;
    v.duvdx = uvs * bx;
    v.duvdy = uvs * by;
    v.position = positions * b;
    v.dpdx = positions * bx;
    v.dpdy = positions * by;

    vec3 normal = mat3(t.instance.normal_model) * (mat3(unpack_normal(t.v0.normal), unpack_normal(t.v1.normal), unpack_normal(t.v2.normal)) * b);
    vec4 t0 = unpack_tangent(t.v0.tangent);
    mat3 tangents = mat3(t0.xyz, unpack_tangent(t.v1.tangent).xyz, unpack_tangent(t.v2.tangent).xyz);
    v.tangent = vec4(mat3(t.instance.model) * (tangents * b), t0.w);
    v.geometric_normal = safe_normalize(normal, vec3(0.0, 1.0, 0.0));
    // Front-facing as the rasteriser defines it: counter-clockwise on screen.
    bool front = dot(cross(t.p1 - t.p0, t.p2 - t.p0), dir) < 0.0;
    if ((v.material.flags & MATERIAL_DOUBLE_SIDED) != 0u && !front) v.geometric_normal = -v.geometric_normal;
    v.skinned = t.mesh.rest != t.mesh.vertices;
    v.rest_position = v.position;
    v.rest_normal = v.geometric_normal;
    if (v.skinned) rest_pose_at(t.instance, t.mesh, t.index, b, normal, v.geometric_normal, v.rest_position, v.rest_normal);
    return v;
}

VisibleSurface visible_surface(ivec2 px, uvec2 ids) {
    InstanceTriangle t = instance_triangle(ids.x, ids.y);
    vec3 eye = scene.camera.camera.position;
    vec3 dir = ray_dir(vec2(px));
    vec3 b = barycentrics(eye, dir, t.p0, t.p1, t.p2);
    vec3 bx = barycentrics(eye, ray_dir(vec2(px) + vec2(1.0, 0.0)), t.p0, t.p1, t.p2) - b;
    vec3 by = barycentrics(eye, ray_dir(vec2(px) + vec2(0.0, 1.0)), t.p0, t.p1, t.p2) - b;
    return triangle_surface(t, b, bx, by, dir);
}

// The surface a ray along `dir` hits on triangle `triangle` of instance slot `instance`, at the
// hit's barycentrics (u, v), where its cone is `width` metres across: the footprint's two steps
// lie in the triangle's plane, across the ray and along it (stretched by the grazing angle).
VisibleSurface hit_surface(uint instance, uint triangle, vec2 hit, vec3 dir, float width) {
    InstanceTriangle t = instance_triangle(instance, triangle);
    vec3 b = vec3(1.0 - hit.x - hit.y, hit.x, hit.y);
    vec3 p = mat3(t.p0, t.p1, t.p2) * b;
    vec3 n = safe_normalize(cross(t.p1 - t.p0, t.p2 - t.p0), vec3(0.0, 1.0, 0.0));
    vec3 across = safe_normalize(cross(n, dir), abs(n.x) < 0.9 ? cross(n, vec3(1.0, 0.0, 0.0)) : cross(n, vec3(0.0, 1.0, 0.0)));
    vec3 along = cross(across, n) / max(abs(dot(dir, n)), 0.1);
    vec3 bx = barycentrics(p + across * width + n, -n, t.p0, t.p1, t.p2) - b;
    vec3 by = barycentrics(p + along * width + n, -n, t.p0, t.p1, t.p2) - b;
    return triangle_surface(t, b, bx, by, dir);
}

#endif
