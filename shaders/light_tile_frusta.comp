#version 460
// Tiled light culling, first pass (seed 001 §4.2.1): each tile's four side planes in view space,
// through the eye and two of the tile's corners, with inward normals, plus the tile's extent one
// metre in front of the eye (the AABB optimisation scales it by the tile's depth range). They
// depend only on the projection, the view size and the tile size, so the renderer runs this
// pass only when one of those changes; the culling pass reads the planes every frame.
#include "scene.glsl"
#include "light_tiles.glsl"

layout(local_size_x = 64) in;

// View-space point on the near plane under pixel corner `px` (the viewport is flipped: row 0 is
// NDC y = +1). Any projection works, symmetric or not.
vec3 corner_ray(mat4 inv_proj, vec2 px) {
    vec2 ndc = vec2(px.x * scene.camera.camera.inv_viewport_size.x * 2.0 - 1.0,
                    1.0 - px.y * scene.camera.camera.inv_viewport_size.y * 2.0);
    vec4 v = inv_proj * vec4(ndc, 1.0, 1.0);
    return v.xyz / v.w;
}

vec4 side_plane(vec3 a, vec3 b, vec3 inside) {
    vec3 n = normalize(cross(a, b));
    return vec4(dot(n, inside) < 0.0 ? -n : n, 0.0);
}

void main() {
    GpuLighting l = scene.lighting.lighting;
    uint t = gl_GlobalInvocationID.x;
    if (t >= l.tiles_x * l.tiles_y) return;
    GpuCamera cam = scene.camera.camera;
    uvec2 tile = uvec2(t % l.tiles_x, t / l.tiles_x);
    vec2 lo = vec2(tile * l.tile_size);
    vec2 hi = min(vec2((tile + 1u) * l.tile_size), cam.viewport_size);
    // Without temporal anti-aliasing's jitter: the frusta are rebuilt when the projection
    // changes, not with every frame's sub-pixel offset (render/src/taa).
    mat4 unjitter = mat4(1.0);
    unjitter[3].xy = -cam.jitter;
    mat4 inv_proj = inverse(unjitter * cam.proj);
    vec3 tl = corner_ray(inv_proj, lo);
    vec3 tr = corner_ray(inv_proj, vec2(hi.x, lo.y));
    vec3 bl = corner_ray(inv_proj, vec2(lo.x, hi.y));
    vec3 br = corner_ray(inv_proj, hi);
    vec3 centre = corner_ray(inv_proj, (lo + hi) * 0.5);
    GpuTileFrustum f;
    f.left = side_plane(tl, bl, centre);
    f.right = side_plane(tr, br, centre);
    f.top = side_plane(tl, tr, centre);
    f.bottom = side_plane(bl, br, centre);
    vec2 c0 = tl.xy / -tl.z, c1 = tr.xy / -tr.z, c2 = bl.xy / -bl.z, c3 = br.xy / -br.z;
    vec2 mn = min(min(c0, c1), min(c2, c3)), mx = max(max(c0, c1), max(c2, c3));
    f.extent = vec4(mn.x, mx.x, mn.y, mx.y);
    TileFrustaRef(l.tile_frusta).frusta[t] = f;
}
