// variants: TRANSPARENT
#version 460
// Tiled light culling, second pass (seed 001 §4.2): one workgroup per tile.
// 1. The tile's depth range from the reverse-Z prepass depth (shared atomics on the float bits,
//    which order like the floats for depths ≥ 0; the largest depth is the nearest). Sky pixels
//    (depth 0) do not count; a tile of sky gets no lights. The TRANSPARENT variant also counts
//    the nearest transparent surface's depth where it is in front (crate::transparency).
// 2. Each light is tested against the tile's volume, a light per thread round-robin: point
//    lights as spheres against the four side planes and the near and far planes (Ericson's
//    sphere-plane test); spot lights also as cones (the hull of the tip and the base disc, whose
//    farthest point from a plane is exact: tip + h·d + r·|n − (n·d)d|); directional lights are
//    in every tile. With LIGHT_CULL_AABB a sphere must also touch the tile volume's view-space
//    AABB (the seed's "AABB optimisation", which it combines with the plane test: a light stays
//    only if it passes both, so the AABB removes the planes' false positives at tile corners
//    without adding its own where the depth range is long).
// 2b. With LIGHT_CULL_DEPTH_MASK, the tile's depth range is cut into 32 slices and a bit set for
//    each slice some pixel lies in (Harada, "A 2.5D culling for Forward+", SIGGRAPH Asia 2012
//    technical briefs): a light whose sphere's depth extent meets no set slice lights no pixel of
//    the tile, however long its range. Where a tile straddles a near object and a far wall, the
//    plane and box tests keep every light between the two; the mask drops those in the gap.
//    The TRANSPARENT variant sets every slice from the nearest glass to the opaque surface
//    behind it (further panes are lit from the same list; over sky the range itself ends at the
//    nearest glass, as it did before the mask). Frames with live or emitting particles cull
//    without the mask (crate::lights), since a particle may float in a gap.
// 3. The survivors, in light order, go into the list at an offset one atomic per tile reserves;
//    the tile's shadow rows are reserved the same way. Results are kept as bit masks in shared
//    memory (up to LIGHT_CULL_SHARED_LIGHTS lights; more are simply tested twice), so no light
//    is ever dropped for want of room in the workgroup.
#extension GL_EXT_control_flow_attributes : require
#include "scene.glsl"
#include "light_tiles.glsl"

layout(local_size_x = 64) in;

shared uint s_depth_min;
shared uint s_depth_max;
shared uint s_count;
shared uint s_offset;
shared bool s_write;
shared uint s_masks[LIGHT_CULL_SHARED_LIGHTS / 32u];
shared uint s_depth_mask;

struct TileVolume {
    vec4 planes[6];
    vec3 box_min;
    vec3 box_max;
    // The depth mask's slices: view distance of slice 0's start, slices per metre (0: one
    // slice), and the occupied slices (all bits when the mask is off).
    float near;
    float slices_per_metre;
    uint depth_mask;
};

// The slice of view distance `z` in the tile's depth mask (clamped to the 32 slices).
uint depth_slice(TileVolume v, float z) {
    return uint(clamp((z - v.near) * v.slices_per_metre, 0.0, 31.0));
}

// The mask bits of slices `first` to `last` (first ≤ last ≤ 31).
uint slice_bits(uint first, uint last) {
    return (0xFFFFFFFFu >> (31u - last)) & (0xFFFFFFFFu << first);
}

bool sphere_outside(vec4 plane, vec3 c, float r) {
    return dot(plane.xyz, c) + plane.w < -r;
}

bool cone_outside(vec4 plane, vec3 tip, vec3 dir, float h, float radius) {
    if (dot(plane.xyz, tip) + plane.w >= 0.0) return false;
    vec3 n = plane.xyz;
    float reach = radius * length(n - dir * dot(n, dir));
    return dot(n, tip + dir * h) + plane.w + reach < 0.0;
}

bool light_in_tile(uint slot, TileVolume v, mat4 view, bool aabb) {
    GpuLight light = scene.lights.lights[slot];
    if (light.kind == LIGHT_DIRECTIONAL) return true;
    if (light.kind == LIGHT_NONE) return false;
    float r = light.range;
    if (!(r > 0.0)) return false;   // no range (or NaN): lights nothing
    vec3 c = (view * vec4(light.position, 1.0)).xyz;
    [[unroll]] for (int i = 0; i < 6; ++i) {
        if (sphere_outside(v.planes[i], c, r)) return false;
    }
    if (light.kind == LIGHT_SPOT && light.cone_cos > 0.05) {
        // The lit region (distance ≤ range, angle ≤ outer) lies in the cone of height `range`.
        vec3 d = normalize(mat3(view) * light.direction);
        float radius = r * light.cone_sin / light.cone_cos;
        [[unroll]] for (int i = 0; i < 6; ++i) {
            if (cone_outside(v.planes[i], c, d, r, radius)) return false;
        }
    }
    if (aabb) {
        vec3 q = clamp(c, v.box_min, v.box_max) - c;
        if (dot(q, q) > r * r) return false;
    }
    // The slices the sphere's depth extent spans (view distance is −z). With the mask off, a
    // tile of one depth (one slice) or a light of unbounded range, there is nothing to test.
    if (v.depth_mask == 0xFFFFFFFFu || !(v.slices_per_metre > 0.0) || isinf(r)) return true;
    uint lo = depth_slice(v, -c.z - r), hi = depth_slice(v, -c.z + r);
    return (slice_bits(lo, hi) & v.depth_mask) != 0u;
}

// View distance of a reverse-Z depth (seed 001 eq. 4.3 with z = −1: −D / (depth + C)).
float view_distance_of(float depth, mat4 proj) {
    return proj[3][2] / (depth + proj[2][2]);
}

void main() {
    GpuLighting l = scene.lighting.lighting;
    GpuCamera cam = scene.camera.camera;
    uint tile = gl_WorkGroupID.y * l.tiles_x + gl_WorkGroupID.x;
    uint lane = gl_LocalInvocationIndex;
    uint light_count = l.light_count;
    bool cached = light_count <= LIGHT_CULL_SHARED_LIGHTS;
    uint mask_words = cached ? (light_count + 31u) / 32u : 2u;
    if (lane == 0u) {
        s_depth_min = floatBitsToUint(1.0 / 0.0);
        s_depth_max = 0u;
        s_count = 0u;
        s_depth_mask = 0u;
    }
    for (uint i = lane; i < mask_words; i += 64u) s_masks[i] = 0u;
    barrier();

    uint ts = l.tile_size;
    uvec2 origin = gl_WorkGroupID.xy * ts;
    ivec2 size = ivec2(cam.viewport_size);
    for (uint i = lane; i < ts * ts; i += 64u) {
        ivec2 px = ivec2(origin + uvec2(i % ts, i / ts));
        if (any(greaterThanEqual(px, size))) continue;
        float d = texelFetch(depth_target, px, 0).r;
#ifdef TRANSPARENT
        // Glass in front of the opaque surface (or of the sky) is shaded too: its depth is one
        // more sample of the tile's range (reverse-Z, nearer is larger). Glass behind the
        // opaque surface is hidden and does not count.
        float t = texelFetch(transparent_depth, px, 0).r;
        if (t > d) {
            atomicMin(s_depth_min, floatBitsToUint(t));
            atomicMax(s_depth_max, floatBitsToUint(t));
        }
#endif
        if (d > 0.0) {
            atomicMin(s_depth_min, floatBitsToUint(d));
            atomicMax(s_depth_max, floatBitsToUint(d));
        }
    }
    barrier();
    bool empty = s_depth_max == 0u;

    TileVolume v;
    bool aabb = (l.flags & LIGHT_CULL_AABB) != 0u;
    bool depth_mask = (l.flags & LIGHT_CULL_DEPTH_MASK) != 0u;
    float near = 0.0, far = 0.0;
    if (!empty) {
        near = view_distance_of(uintBitsToFloat(s_depth_max), cam.proj);
        far = view_distance_of(uintBitsToFloat(s_depth_min), cam.proj);
    }
    v.near = near;
    v.slices_per_metre = far > near ? 32.0 / (far - near) : 0.0;
    if (depth_mask && !empty) {
        // Second look at the tile's pixels: the slices they (and glass in front) lie in.
        for (uint i = lane; i < ts * ts; i += 64u) {
            ivec2 px = ivec2(origin + uvec2(i % ts, i / ts));
            if (any(greaterThanEqual(px, size))) continue;
            float d = texelFetch(depth_target, px, 0).r;
            uint bits = d > 0.0 ? 1u << depth_slice(v, view_distance_of(d, cam.proj)) : 0u;
#ifdef TRANSPARENT
            // Glass in front: every slice from the nearest pane to the opaque surface (or to the
            // range's end over sky), since panes further back are shaded from this list too.
            float t = texelFetch(transparent_depth, px, 0).r;
            if (t > d) {
                uint first = depth_slice(v, view_distance_of(t, cam.proj));
                uint last = d > 0.0 ? depth_slice(v, view_distance_of(d, cam.proj)) : 31u;
                bits |= slice_bits(first, last);
            }
#endif
            if (bits != 0u) atomicOr(s_depth_mask, bits);
        }
    }
    barrier();
    v.depth_mask = depth_mask ? s_depth_mask : 0xFFFFFFFFu;
    if (!empty) {
        GpuTileFrustum f = TileFrustaRef(l.tile_frusta).frusta[tile];
        v.planes[0] = f.left;
        v.planes[1] = f.right;
        v.planes[2] = f.top;
        v.planes[3] = f.bottom;
        v.planes[4] = vec4(0.0, 0.0, -1.0, -near);   // in front of the nearest pixel: -z ≥ near
        v.planes[5] = vec4(0.0, 0.0, 1.0, far);      // behind the farthest: -z ≤ far
        vec4 e = f.extent;
        v.box_min = vec3(min(e.x * near, e.x * far), min(e.z * near, e.z * far), -far);
        v.box_max = vec3(max(e.y * near, e.y * far), max(e.w * near, e.w * far), -near);

        // Test every light once; keep the results when they fit in shared memory.
        uint mine = 0u;
        for (uint i = lane; i < light_count; i += 64u) {
            if (light_in_tile(i, v, cam.view, aabb)) {
                ++mine;
                if (cached) atomicOr(s_masks[i / 32u], 1u << (i % 32u));
            }
        }
        if (mine > 0u) atomicAdd(s_count, mine);
    }
    barrier();

    LightTileWordsRef w = light_tile_words();
    uint count = s_count;
    if (lane == 0u) {
        if (tile == 0u) atomicAdd(w.words[LSTAT_FRAME], 1u);
        uint g = grid_at(tile);
        uint offset = 0u, rows = NO_SHADOW_ROWS;
        bool fits = true;
        if (count > 0u) {
            offset = atomicAdd(w.words[LSTAT_ENTRIES], count);
            fits = offset + count <= l.list_capacity;
            bool shadows = (l.flags & SHADOWS_TRACED) != 0u;
            if (shadows) {
                uint row_count = (count + 31u) / 32u;
                uint row = atomicAdd(w.words[LSTAT_ROWS], row_count);
                if (row + row_count <= l.shadow_rows) rows = row;
            }
            if (!fits || (shadows && rows == NO_SHADOW_ROWS)) atomicAdd(w.words[LSTAT_OVERFLOWED], 1u);
            atomicMax(w.words[LSTAT_MAX], count);
            atomicAdd(w.words[LSTAT_TILES_USED], 1u);
            // The shadow pass and shading compare the same count (samples_lights).
            if (fits && rows != NO_SHADOW_ROWS && count > l.sampled_lights_above) atomicAdd(w.words[LSTAT_SAMPLED], 1u);
        }
        w.words[g] = offset;
        w.words[g + 1u] = fits ? count : (count | LIGHT_TILE_OVERFLOW);
        w.words[g + 2u] = rows;
        s_offset = offset;
        s_write = fits && count > 0u;
    }
    barrier();
    if (!s_write) return;

    // Write the survivors in light order, 64 lights at a time: each thread's place is the
    // number of survivors before it (bit counts of the masks).
    uint at = list_at() + s_offset;
    for (uint base = 0u; base < light_count; base += 64u) {
        uint i = base + lane;
        uint word0, word1;
        if (cached) {
            word0 = s_masks[base / 32u];
            word1 = base + 32u < light_count ? s_masks[base / 32u + 1u] : 0u;
        } else {
            barrier();
            if (lane < 2u) s_masks[lane] = 0u;
            barrier();
            if (i < light_count && light_in_tile(i, v, cam.view, aabb)) atomicOr(s_masks[lane / 32u], 1u << (lane % 32u));
            barrier();
            word0 = s_masks[0];
            word1 = s_masks[1];
        }
        uint word = lane < 32u ? word0 : word1;
        uint bit = 1u << (lane % 32u);
        if (i < light_count && (word & bit) != 0u) {
            uint before = (lane < 32u ? 0u : bitCount(word0)) + bitCount(word & (bit - 1u));
            // Retested lights (past the shared-memory cache) could in principle round the other
            // way than when they were counted: never write past the tile's reserved range.
            if (at + before < list_at() + s_offset + count) w.words[at + before] = i;
        }
        at += bitCount(word0) + bitCount(word1);
    }
}
