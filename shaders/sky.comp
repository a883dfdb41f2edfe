// variants: COVERAGE
#version 460
// The sky pass (render/src/environment): pixels no geometry covers (reverse-Z depth 0) show the
// environment in their view direction, sharp (the radiance cube's level 0), and the procedural
// sky's sun disc. COVERAGE (MSAA, render/src/msaa): the HDR target holds the mean of a pixel's
// samples, cleared transparent black, with the covered fraction in alpha; the sky adds itself
// over the rest.
#include "environment.glsl"
#include "depth.glsl"
#include "storable.glsl"

layout(set = 0, binding = BINDING_ENVIRONMENT_SOURCE) uniform samplerCube environment_source;
#ifdef COVERAGE
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform image2D hdr_image;
#else
layout(set = 0, binding = BINDING_HDR_STORAGE, rgba16f) uniform writeonly image2D hdr_image;
#endif
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    GpuCamera cam = scene.camera.camera;
    if (any(greaterThanEqual(px, ivec2(cam.viewport_size)))) return;
#ifdef COVERAGE
    vec4 covered = imageLoad(hdr_image, px);
    if (covered.a >= 1.0) return;
#else
    if (texelFetch(depth_target, px, 0).r != 0.0) return;
#endif
    vec3 d = normalize(world_from_depth(vec2(px), 1.0) - cam.position);   // through the near plane
    GpuLighting l = scene.lighting.lighting;
    vec3 radiance = textureLod(environment_source, environment_direction(d), 0.0).rgb * l.environment_intensity;
    if ((l.environment_flags & ENVIRONMENT_SUN_DISC) != 0u) {
        GpuEnvironment env = EnvironmentRef(l.environment).environment;
        float cos_disc = env.sun.w;
        // The disc's radiance: the sun's illuminance over the disc's solid angle, 2π(1 − cos r).
        if (dot(d, env.sun.xyz) >= cos_disc) radiance += env.sun_color.rgb / (2.0 * PI * (1.0 - cos_disc));
    }
#ifdef COVERAGE
    imageStore(hdr_image, px, vec4(storable_radiance(covered.rgb + radiance * (1.0 - covered.a)), 1.0));
#else
    imageStore(hdr_image, px, vec4(storable_radiance(radiance), 1.0));
#endif
}
