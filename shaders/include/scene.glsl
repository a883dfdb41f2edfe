// Scene records shared by every pass. The records (`Gpu*` structs), the push constants and the
// shared constants are generated into layout.glsl from render/src/layout.rs, the one description
// Rust and GLSL follow; this file holds only what GLSL alone needs: the buffer-reference blocks
// and the bindless arrays.
// Buffers are reached through buffer device addresses in the push constants, so a buffer that
// grows needs no descriptor update; textures are one bindless array in set 0.
#ifndef SCENE_GLSL
#define SCENE_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_scalar_block_layout : require

#include "layout.glsl"
#include "vertex.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VerticesRef { GpuVertex vertices[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer IndicesRef { uint indices[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshesRef { GpuMeshInfo meshes[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CameraRef { GpuCamera camera; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer InstancesRef { GpuInstance instances[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MaterialsRef { GpuMaterial materials[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LightsRef { GpuLight lights[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LightingRef { GpuLighting lighting; };

layout(set = 0, binding = 0) uniform sampler2D textures[];
// Render targets, one binding each (BINDING_* in layout.glsl): a shader statically uses only
// the targets its pass samples, which is what the frame graph declares.
layout(set = 0, binding = BINDING_HDR) uniform sampler2D hdr_target;
layout(set = 0, binding = BINDING_DEPTH) uniform sampler2D depth_target;
layout(set = 0, binding = BINDING_GBUFFER_ALBEDO) uniform sampler2D gbuffer_albedo;
layout(set = 0, binding = BINDING_GBUFFER_NORMAL) uniform sampler2D gbuffer_normal;
layout(set = 0, binding = BINDING_GBUFFER_MATERIAL) uniform sampler2D gbuffer_material;
layout(set = 0, binding = BINDING_GBUFFER_LAYERS) uniform usampler2D gbuffer_layers;
layout(set = 0, binding = BINDING_VISIBILITY) uniform usampler2D visibility_ids;
layout(set = 0, binding = BINDING_TRANSPARENT_DEPTH) uniform sampler2D transparent_depth;
layout(set = 0, binding = BINDING_TRANSPARENCY_SOURCE) uniform sampler2D transparency_source;
layout(set = 0, binding = BINDING_SHADOW_MAP_DEPTH) uniform sampler2D shadow_map_depth;
layout(set = 0, binding = BINDING_SHADOW_MAP_FILTER) uniform sampler2D shadow_map_filter;
layout(set = 0, binding = BINDING_BACKGROUND_DEPTH) uniform sampler2D background_depth;
layout(set = 0, binding = BINDING_ANTIALIASED) uniform sampler2D antialiased;

vec4 sample_texture(uint index, vec2 uv) {
    return texture(textures[nonuniformEXT(index)], uv);
}

#endif
