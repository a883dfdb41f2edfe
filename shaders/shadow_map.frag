#version 460
// The shadow-map pass's fragment stage (seed 002 §3.2.1): depth is tested and written as in any
// shadow map; the filter target gets (1, 1, 1, 1) from opaque surfaces and, with coloured
// shadows, glass's colour and opacity on odd rows only: glass fragments on even rows are
// dropped, so there the depth is the opaque surface's behind the glass, and a lookup that reads
// both rows of a pair sees both. Masked materials are alpha-tested as in the depth prepass;
// without coloured shadows glass is drawn like an opaque surface.
#include "scene.glsl"
#include "mesh_io.glsl"

layout(location = 0) out vec4 o_filter;

void main() {
    GpuMaterial m = scene.materials.materials[v_material];
    bool masked = (m.flags & MATERIAL_ALPHA_MASK) != 0u;
    bool blended = (m.flags & MATERIAL_BLEND) != 0u;
    o_filter = vec4(1.0);
    if (!masked && !blended) return;
    vec4 c = vec4(m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3]) * sample_texture(m.base_color_tex, v_uv);
    if (!blended) {
        if (c.a < m.alpha_cutoff) discard;
        return;
    }
    if ((scene.lighting.lighting.flags & COLOURED_SHADOWS) == 0u) return;
    if ((int(gl_FragCoord.y) & 1) == 0) discard;
    o_filter = clamp(c, 0.0, 1.0);
}
