#version 460
// Depth prepass for alpha-masked materials: discard below the cutoff so the shading pass, which
// tests depth EQUAL, never shades the holes. Opaque materials use no fragment shader at all.
#include "scene.glsl"
#include "mesh_io.glsl"

void main() {
    GpuMaterial m = scene.materials.materials[v_material];
    float alpha = m.base_color.a * sample_texture(m.base_color_tex, v_uv).a;
    if (alpha < m.alpha_cutoff) discard;
}
