// variants: GBUFFER GBUFFER+RAY_QUERY_DECALS GBUFFER+DECAL_BUFFER RAY_QUERY_DECALS DECAL_BUFFER CLUSTERED_DECALS
#version 460
// The reflection pass's rays (render/src/reflections): each pixel rebuilds its surface as its
// pipeline's shading does (the G-buffer with GBUFFER, else the visibility ids), applies the
// frame's decals the same way (they may make it smoother or rougher), and stores the weight its
// reflection gets; pixels smoother than the cut-off trace a reflection ray (reflections.glsl),
// all of them at full resolution, one per 2×2 block at half (REFLECT_HALF_RES: the block's
// first pixel that reflects). reflections_resolve.comp filters what they bring back and adds it
// to the HDR target.
#include "reflections.glsl"
#ifdef GBUFFER
#include "deferred_surface.glsl"
#endif

layout(set = 0, binding = BINDING_REFLECTION, rgba16f) uniform writeonly image2D reflection_out;
layout(set = 0, binding = BINDING_REFLECTION_WEIGHT, rgba16f) uniform writeonly image2D weight_out;
layout(local_size_x = 8, local_size_y = 8) in;

const uint NO_TRACER = 0xFFFFFFFFu;
shared uint block_tracer[16];   // per 2×2 block of the workgroup: the invocation that traces
shared uint counts[6];          // REFLECTION_STAT_* of the workgroup

bool primary_surface(ivec2 px, out SurfaceInputs s) {
#ifdef GBUFFER
    return deferred_surface(px, s);
#else
    return visbuffer_surface(px, s);
#endif
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    uint local = gl_LocalInvocationIndex;
    if (local < 16u) block_tracer[local] = NO_TRACER;
    if (local < 6u) counts[local] = 0u;
    barrier();

    GpuCamera cam = scene.camera.camera;
    GpuLighting l = scene.lighting.lighting;
    bool half_res = (l.reflection_flags & REFLECT_HALF_RES) != 0u;
    bool inside = all(lessThan(px, ivec2(cam.viewport_size)));
    SurfaceInputs s;
    bool surface = inside && primary_surface(px, s);
    float fade = 0.0;
    vec3 v = vec3(0.0, 0.0, 1.0), n = v, facing = v;
    if (surface) {
        apply_surface_decals(s, px);
        v = normalize(cam.position - s.position);
        facing = dot(s.geometric_normal, v) < 0.0 ? -s.geometric_normal : s.geometric_normal;
        n = dot(s.normal, v) > 1e-3 ? s.normal : facing;
        fade = clamp((l.reflection_cutoff - s.roughness) / (0.25 * l.reflection_cutoff), 0.0, 1.0);
    }
    bool reflects = fade > 0.0;
    if (inside) {
        vec3 weight = vec3(0.0);
        if (reflects) {
            SurfaceBrdf brdf = surface_brdf(s.albedo, s.metallic, s.roughness);
            weight = env_brdf_approx(brdf.f0, brdf.roughness, clamp(dot(n, v), 1e-4, 1.0)) * s.occlusion * fade;
        }
        imageStore(weight_out, px, vec4(weight, reflects ? s.roughness : -1.0));
    }

    uvec2 in_group = gl_LocalInvocationID.xy;
    uint block = (in_group.y / 2u) * 4u + in_group.x / 2u;
    if (half_res && reflects) atomicMin(block_tracer[block], local);
    barrier();
    bool traces = reflects && (!half_res || block_tracer[block] == local);
    ivec2 store = half_res ? px / 2 : px;
    if (traces) {
        // The pixel's cone: its width where it meets the surface, spreading by a pixel's angle,
        // and by the lobe's width on glossy surfaces.
        float pixel_angle = 2.0 / (cam.proj[1][1] * cam.viewport_size.y);
        float distance = length(cam.position - s.position);
        float spread = pixel_angle + (s.roughness < REFLECTION_MIRROR ? 0.0 : 0.5 * s.roughness * s.roughness);
        vec3 dir = reflection_direction(n, v, s.roughness, pixel_noise(uvec2(px)));
        ReflectionRay r = trace_reflection(shadow_origin(s.position, facing), dir, distance * pixel_angle, spread);
        vec3 radiance = r.radiance;
        if (scene.debug_view == DEBUG_REFLECTIONS) radiance = r.hit ? heatmap(r.distance / 16.0) : vec3(1.0);
        imageStore(reflection_out, store, vec4(radiance, distance));
        atomicAdd(counts[REFLECTION_STAT_RAYS], 1u);
        if (r.hit) atomicAdd(counts[REFLECTION_STAT_HITS], 1u);
        if (r.glass) atomicAdd(counts[REFLECTION_STAT_GLASS], 1u);
        atomicAdd(counts[REFLECTION_STAT_DECALS_TESTED], r.decals_tested);
        atomicAdd(counts[REFLECTION_STAT_LIGHTS], r.lights_found);
    } else if (inside && (!half_res || (block_tracer[block] == NO_TRACER && all(equal(in_group % 2u, uvec2(0)))))) {
        imageStore(reflection_out, store, vec4(0.0));   // nothing traced here
    }
    if (reflects) atomicAdd(counts[REFLECTION_STAT_PIXELS], 1u);
    barrier();
    if (local < 6u && l.reflection_stats != 0ul && counts[local] != 0u) {
        atomicAdd(ReflectionStatsRef(l.reflection_stats).words[local], counts[local]);
    }
}
