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

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VerticesRef { GpuVertex vertices[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer IndicesRef { uint indices[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshesRef { GpuMeshInfo meshes[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer CameraRef { GpuCamera camera; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer InstancesRef { GpuInstance instances[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MaterialsRef { GpuMaterial materials[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer LightsRef { GpuLight lights[]; };

layout(set = 0, binding = 0) uniform sampler2D textures[];
layout(set = 0, binding = 1) uniform usampler2D uint_textures[];

vec4 sample_texture(uint index, vec2 uv) {
    return texture(textures[nonuniformEXT(index)], uv);
}

#endif
