// variants: ALPHA_MASK
#version 460
// Visibility buffer (seed 000 §3.4.1, §5.1.3): instance and triangle ids only. Alpha-masked
// materials are tested here (the seed's renderer skipped this, so masked holes were filled).
#include "scene.glsl"
#include "mesh_io.glsl"

layout(location = 0) out uvec2 out_ids;

void main() {
#ifdef ALPHA_MASK
    GpuMaterial m = scene.materials.materials[v_material];
    if (m.base_color.a * sample_texture(m.base_color_tex, v_uv).a < m.alpha_cutoff) discard;
#endif
    out_ids = uvec2(v_instance, uint(gl_PrimitiveID) + v_triangle_base);
}
