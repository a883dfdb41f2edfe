#version 460
// Deferred decals (seed 000 §3.2, §5.1.2.1), the comparison technique: for each pixel a box
// covers, reconstruct the position from depth, test it against the oriented box, and
// alpha-blend the decal's attributes into the G-buffer (the pipeline's blend state and write
// masks do the blending; decals are drawn in channel-then-weight order, so later ones land on
// top). Emission adds to the HDR target, which holds the surfaces' emission until lighting adds
// to it (blend.glsl: decals add light). The decal evaluation is the same function ray-query
// decals use.
#include "scene.glsl"
#include "depth.glsl"
#include "decals.glsl"

layout(location = 0) flat in uint v_slot;
layout(location = 0) out vec4 gb_albedo;
layout(location = 1) out vec4 gb_normal;
layout(location = 2) out vec4 gb_material;
layout(location = 3) out vec4 out_emissive;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(depth_target, px, 0).r;
    if (depth <= 0.0) discard;
    vec3 position = world_from_depth(vec2(px), depth);
    vec3 dpdx, dpdy;
    world_derivatives(px, depth, position, dpdx, dpdy);
    vec3 n = safe_normalize(cross(dpdy, dpdx), vec3(0.0, 1.0, 0.0));
    vec3 to_eye = scene.camera.camera.position - position;
    n = dot(n, to_eye) < 0.0 ? -n : n;
    // The G-buffer normal cannot be read while it is blended into. Decals on a skin are not
    // drawn as boxes (their box is in the rest pose): decal_world_view lets only world decals in.
    DecalSurface s = decal_world_view(position, dpdx, dpdy, n, n, texelFetch(gbuffer_layers, px, 0).r & 0xFFu);

    DecalBlend b;
    blend_init(b);
    apply_decal(b, v_slot, s);
    uint c = decal_channel(decal_record(v_slot));
    // One decal in its channel: sum / weight is its value, 1 − visibility its alpha.
    vec4 w = b.weight[c];
    if (w.x + w.y + w.z + w.w <= 0.0 && all(equal(b.emissive, vec3(0.0)))) discard;
    gb_albedo = w.x > 0.0 ? vec4(b.albedo[c].rgb / w.x, 1.0 - b.albedo[c].a) : vec4(0.0);
    gb_normal = w.y > 0.0 ? vec4(safe_normalize(b.normal[c].xyz, s.normal) * 0.5 + 0.5, 1.0 - b.normal[c].w) : vec4(0.0);
    // Roughness and metallic share one attachment and so one alpha (the write mask keeps the
    // one the decal does not set).
    float rough_a = 1.0 - b.spec[c].z;
    float metal_a = 1.0 - b.spec[c].w;
    out_emissive = vec4(scene.debug_view == DEBUG_LIT ? b.emissive : vec3(0.0), 0.0);
    gb_material = vec4(w.z > 0.0 ? b.spec[c].x / w.z : 0.0, w.w > 0.0 ? b.spec[c].y / w.w : 0.0, 0.0, max(rough_a, metal_a));
}
