#version 460
// GPU skinning (render/src/skinning): morph targets (glTF 2.0 §3.7.2.2), then linear blend
// skinning (§3.7.3) of this frame's posed meshes, one invocation per vertex, a row of workgroups
// per job. Each posed mesh gets its rest-pose vertices offset by its weighted morph targets, then
// moved by the blend of its four joints' matrices (none without a skin); normals and tangents by
// the blend's cofactor (perpendicular under uneven scale too); its previous positions (behind its
// vertices, a vec4 each) keep the positions this pass overwrites, for motion vectors.
#define NO_SCENE_PUSH
#include "scene.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform SkinPushBlock { GpuSkinPush p; };

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer JobsRef { GpuSkinJob jobs[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer PaletteRef { GpuJointMatrix joints[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer SkinRef { GpuSkinVertex skin[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer PosedRef { GpuVertex vertices[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer PreviousRef { vec4 positions[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MorphsRef { GpuMorphDelta deltas[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer WeightsRef { float weights[]; };

// A mesh's table of its levels' vertices (MeshLods::skin_table): per coarser level its first
// word and its vertex count, each vertex's coarsest level (a byte a vertex), each level's vertices.
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LevelsRef { uint words[]; };

// Vertex `v`'s coarsest level of detail.
uint vertex_level(LevelsRef table, uint v) {
    return (table.words[2u * LOD_LEVELS + (v >> 2u)] >> ((v & 3u) * 8u)) & 0xFFu;
}

// The joint's 3×4 matrix as a mat4x3 (columns: the three axes and the translation).
mat4x3 joint_matrix(uint index) {
    GpuJointMatrix m = PaletteRef(p.palette).joints[index];
    return transpose(mat3x4(m.x, m.y, m.z));
}

void main() {
    uint job_index = gl_WorkGroupID.y + gl_WorkGroupID.z * gl_NumWorkGroups.y;
    if (job_index >= p.job_count) return;
    GpuSkinJob job = JobsRef(p.jobs).jobs[job_index];
    GpuMeshInfo mesh = MeshesRef(p.meshes).meshes[job.mesh];
    uint v = gl_WorkGroupID.x * 64u + gl_LocalInvocationID.x;
    if (mesh.rest == 0ul || (mesh.skin == 0ul && mesh.morph_targets == 0u)) return;
    // A far instance skins only the vertices of the level of detail it will be drawn at
    // (render/src/skinning), the level's own list; a vertex its last skinning left out has no
    // previous position.
    uint level = job.levels & SKIN_LEVEL_MASK;
    uint own = 0u;
    if (mesh.vertex_levels != 0ul) {
        LevelsRef table = LevelsRef(mesh.vertex_levels);
        if (level > 0u) {
            if (v >= table.words[LOD_LEVELS + level - 1u]) return;
            v = table.words[table.words[level - 1u] + v];
        }
        if (v >= mesh.vertex_count) return;
        own = vertex_level(table, v);
    } else if (v >= mesh.vertex_count) {
        return;
    }
    bool first = (job.levels & SKIN_FIRST) != 0u || own < (job.levels >> SKIN_PREVIOUS_SHIFT & SKIN_LEVEL_MASK);

    GpuVertex packed = VerticesRef(mesh.rest).vertices[v];
    vec3 rest_position = packed.position;
    vec3 rest_normal = unpack_normal(packed.normal);
    vec4 rest_tangent = unpack_tangent(packed.tangent);
    for (uint t = 0u; t < mesh.morph_targets; ++t) {
        float w = WeightsRef(p.weights).weights[job.weights + t];
        if (w == 0.0) continue;
        GpuMorphDelta d = MorphsRef(mesh.morphs).deltas[t * mesh.vertex_count + v];
        rest_position += w * d.position;
        rest_normal += w * d.normal;
    }

    mat4x3 m = mat4x3(1.0);   // no skin: the morphed rest pose as it is
    if (mesh.skin != 0ul) {
        GpuSkinVertex s = SkinRef(mesh.skin).skin[v];
        uvec4 joints = uvec4(s.joints01 & 0xFFFFu, s.joints01 >> 16, s.joints23 & 0xFFFFu, s.joints23 >> 16);
        vec4 weights = vec4(unpackUnorm2x16(s.weights01), unpackUnorm2x16(s.weights23));
        weights /= max(weights.x + weights.y + weights.z + weights.w, 1e-6);
        m = weights.x * joint_matrix(job.palette + joints.x);
        if (weights.y > 0.0) m += weights.y * joint_matrix(job.palette + joints.y);
        if (weights.z > 0.0) m += weights.z * joint_matrix(job.palette + joints.z);
        if (weights.w > 0.0) m += weights.w * joint_matrix(job.palette + joints.w);
    }
    mat3 linear = mat3(m);
    // Cofactor matrix: the inverse transpose times the determinant (normals need only the
    // direction, and it exists for singular matrices too).
    mat3 cofactor = mat3(cross(linear[1], linear[2]), cross(linear[2], linear[0]), cross(linear[0], linear[1]));
    vec3 normal = cofactor * rest_normal;
    vec3 tangent = linear * rest_tangent.xyz;
    float nl = dot(normal, normal), tl = dot(tangent, tangent);

    PosedRef posed = PosedRef(mesh.vertices);
    PreviousRef previous = PreviousRef(previous_positions(mesh.vertices, mesh.vertex_count));
    vec3 position = m * vec4(rest_position, 1.0);
    previous.positions[v] = vec4(first ? position : posed.vertices[v].position, 1.0);
    // The posed copy is packed as the rest pose is (vertex.glsl); its UV is the rest pose's.
    GpuVertex out_v;
    out_v.position = position;
    out_v.normal = nl > 1e-20 ? pack_normal(normal) : packed.normal;
    out_v.uv = packed.uv;
    out_v.tangent = tl > 1e-20 ? pack_tangent(vec4(tangent, rest_tangent.w)) : packed.tangent;
    posed.vertices[v] = out_v;
}
