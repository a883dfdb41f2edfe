// Scene records shared by every pass. Each struct mirrors a `Gpu*` type in
// render/src/scene.rs (std430, same field order); change both together.
// Buffers are reached through buffer device addresses in the push constants, so a buffer that
// grows needs no descriptor update; textures are one bindless array in set 0.
#ifndef SCENE_GLSL
#define SCENE_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_scalar_block_layout : require

struct GpuCamera {
    mat4 view;
    mat4 proj;
    mat4 view_proj;
    mat4 inv_view_proj;
    vec3 position;
    float exposure;
    vec2 viewport_size;
    vec2 inv_viewport_size;
    vec3 ambient;       // uniform ambient radiance, scaled by material occlusion
    uint pad0;
};

struct GpuInstance {
    mat4 model;
    mat4 normal_model;  // inverse-transpose of model
    uint material;
    uint decal_layers;  // decal receiver layers
    uint mesh;          // index into the mesh table (visibility buffer)
    uint pad1;
};

struct GpuVertex { float px, py, pz, nx, ny, nz, u, v, tx, ty, tz, tw; };
struct GpuMeshInfo { uint64_t vertices; uint64_t indices; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VerticesRef { GpuVertex vertices[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer IndicesRef { uint indices[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshesRef { GpuMeshInfo meshes[]; };

const uint MATERIAL_ALPHA_MASK = 1u;
const uint MATERIAL_DOUBLE_SIDED = 2u;

struct GpuMaterial {
    vec4 base_color;
    vec3 emissive;
    float normal_scale;
    float metallic;
    float roughness;
    float alpha_cutoff;
    float occlusion_strength;
    uint base_color_tex;
    uint metallic_roughness_tex;  // G = roughness, B = metallic (glTF)
    uint normal_tex;
    uint occlusion_tex;           // R
    uint emissive_tex;
    uint flags;
    uint pad0;
    uint pad1;
};

const uint LIGHT_NONE = 0u;
const uint LIGHT_POINT = 1u;
const uint LIGHT_SPOT = 2u;
const uint LIGHT_DIRECTIONAL = 3u;

struct GpuLight {
    vec3 position;
    float range;
    vec3 color;       // colour × intensity (candela; lux for directional lights)
    uint kind;
    vec3 direction;   // the direction the light travels (spot, directional)
    float spot_scale; // 1 / (cos inner − cos outer)
    float spot_offset;// −cos outer × spot_scale
    float pad0;
    float pad1;
    float pad2;
};

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CameraRef { GpuCamera camera; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer InstancesRef { GpuInstance instances[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MaterialsRef { GpuMaterial materials[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LightsRef { GpuLight lights[]; };

layout(push_constant) uniform ScenePush {
    CameraRef camera;
    InstancesRef instances;
    MaterialsRef materials;
    LightsRef lights;
    uint64_t decals;           // DecalsRef (decals.glsl)
    uint64_t decal_materials;  // DecalMaterialsRef
    uint64_t decal_tlas;       // acceleration structure address; 0 without decals
    uint64_t decal_aabbs;      // the boxes the decal BLAS is built from
    uint64_t meshes;           // MeshesRef: vertex and index addresses per mesh
    uint64_t decal_order;      // deferred decals: live decal slots sorted by channel, then weight
    uint light_count;     // high-water mark of light slots; empty slots have kind LIGHT_NONE
    uint texture_index;   // a pass's own input image (full-screen passes)
    uint debug_view;      // DebugView in renderer.rs
    uint decal_count;     // live decals; 0 skips the decal loop
} scene;

const uint DEBUG_LIT = 0u;
const uint DEBUG_DECAL_HEATMAP = 1u;
const uint DEBUG_ALBEDO = 2u;
const uint DEBUG_NORMAL = 3u;
const uint DEBUG_ROUGHNESS_METALLIC = 4u;
const uint DEBUG_DECAL_COUNT = 5u;

layout(set = 0, binding = 0) uniform sampler2D textures[];
layout(set = 0, binding = 1) uniform usampler2D uint_textures[];

// Bindless slots of the render targets (render/src/targets.rs).
const uint SLOT_HDR = 2u;
const uint SLOT_DEPTH = 3u;
const uint SLOT_GBUFFER_ALBEDO = 4u;
const uint SLOT_GBUFFER_NORMAL = 5u;
const uint SLOT_GBUFFER_MATERIAL = 6u;
const uint UINT_SLOT_LAYERS = 0u;
const uint UINT_SLOT_VISIBILITY = 1u;

vec4 sample_texture(uint index, vec2 uv) {
    return texture(textures[nonuniformEXT(index)], uv);
}

#endif
