// variants: VISIBILITY GBUFFER
#version 460
// Motion vectors, first pass (render/src/motion): every pixel's motion as if nothing but the
// camera moved, from depth. The point under the pixel (homogeneous, so that the sky, at infinite
// depth, moves as a direction) is projected by this frame's and the previous frame's unjittered
// view-projections. The movers pass then draws what moved by itself over this.
// VISIBILITY, GBUFFER: where the pixel's instance and triangle are known (the visibility buffer;
// the G-buffer's layers, which name a posed mesh's instance), a posed mesh's pixels also get
// their skin's motion here: the camera ray's barycentrics on the triangle weigh the skinning
// pass's previous positions of its corners. Those instances are then left out of the movers
// pass unless they moved as a whole too.
#include "scene.glsl"
#include "motion.glsl"
#if defined(VISIBILITY) || defined(GBUFFER)
#include "visibility.glsl"
#endif

layout(set = 0, binding = BINDING_MOTION, rgba16f) uniform writeonly image2D motion_out;
layout(local_size_x = 8, local_size_y = 8) in;

#if defined(VISIBILITY) || defined(GBUFFER)
// Where the skin under pixel `px` was in the previous frame, if a posed mesh is there.
bool skin_before(ivec2 px, out vec4 before) {
#ifdef VISIBILITY
    uvec2 ids = texelFetch(visibility_ids, px, 0).rg;
    uint instance = ids.x, triangle = ids.y;
#else
    uvec2 layers = texelFetch(gbuffer_layers, px, 0).rg;
    if (layers.y == 0u) return false;
    uint instance = layers.y - 1u, triangle = layers.x >> 8;
#endif
    GpuInstance inst = scene.instances.instances[instance];
    GpuMeshInfo mesh = MeshesRef(scene.meshes).meshes[inst.mesh];
    if (mesh.rest == mesh.vertices || triangle * 3u >= mesh.index_count) return false;
    InstanceTriangle t = instance_triangle(instance, triangle);
    vec3 b = barycentrics(scene.camera.camera.position, ray_dir(vec2(px)), t.p0, t.p1, t.p2);
    IndicesRef indices = IndicesRef(mesh.indices);
    PreviousPositionsRef previous = PreviousPositionsRef(previous_positions(mesh.vertices, mesh.vertex_count));
    mat3 corners = mat3(previous.positions[indices.indices[triangle * 3u]].xyz, previous.positions[indices.indices[triangle * 3u + 1u]].xyz,
                        previous.positions[indices.indices[triangle * 3u + 2u]].xyz);
    before = inst.model * vec4(corners * b, 1.0);
    return true;
}
#endif

void main() {
    ivec2 size = textureSize(depth_target, 0);
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, size))) return;
    GpuCamera cam = scene.camera.camera;
    float depth = texelFetch(depth_target, px, 0).r;
    // The viewport is flipped (include/depth.glsl): row 0 is NDC y = +1.
    vec2 ndc = ((vec2(px) + 0.5) / vec2(size) * 2.0 - 1.0) * vec2(1.0, -1.0);
    vec4 world = cam.inv_view_proj * vec4(ndc, depth, 1.0);
    vec4 world_before = world;
#if defined(VISIBILITY) || defined(GBUFFER)
    vec4 skin;
    if (depth > 0.0 && skin_before(px, skin)) world_before = skin;
#endif
    vec4 now = cam.motion_view_proj * world;
    vec4 before = cam.prev_view_proj * world_before;
    // View depths: the clip w of a point, once the homogeneous point is divided out.
    bool sky = depth <= 0.0;
    float depth_now = sky ? MOTION_FAR : abs(now.w / world.w);
    float depth_before = sky ? MOTION_FAR : abs(before.w / world_before.w);
    imageStore(motion_out, px, motion_record(now, before, depth_now, depth_before));
}
