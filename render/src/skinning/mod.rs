//! GPU skinning: linear blend skinning (glTF 2.0 §3.7.3, "Skins") in a compute pass, written
//! into a posed copy of the mesh that every other pass reads as an ordinary mesh.
//!
//! **Design.** A skinned instance draws a *posed mesh* ([`crate::scene::SceneMirror::add_posed_mesh`]):
//! a mesh of the pool ([`crate::scene::pool`]) with vertices of its own (and, behind them, the
//! previous frame's positions for motion vectors), while its indices, rest-pose vertices and
//! joint weights stay its source's (`GpuMeshInfo::rest`, `GpuMeshInfo::skin`). Culling, the
//! indirect draws, the depth prepass, the visibility buffer, shadow maps, the decal id prepass,
//! glass and the scene BLAS read it like any other mesh, so none of them knows about skins.
//! Engines that skin in the vertex shader (Bevy, three.js) repeat the work in every pass that
//! draws the mesh and cannot hand a ray tracer the pose; skinning once into a buffer is what
//! ray tracing needs anyway (the BLAS is built from it).
//!
//! - **Work follows the pose.** Only posed meshes whose pose was set this frame are skinned
//!   ([`crate::scene::SceneMirror::set_pose`]), plus, once, those posed the frame before, so
//!   that their previous positions catch up with a pose that stopped changing, and those that
//!   have not changed for [`crate::scene::poses::REST_FRAMES`] frames, whole, once. A frame in
//!   which no pose changed, caught up or came to rest dispatches nothing and uploads nothing.
//! - **A far character skins its level of detail only.** Levels of detail (`crate::lod`) are
//!   triangle lists over the mesh's own vertices, each over a subset of the one before, so each
//!   vertex has a coarsest level, and each level a list of its vertices (in the mesh pool,
//!   `MeshLods::skin_table`).
//!   Once the acceleration structures know their refits, [`Skinning::choose_levels`] works out on
//!   the CPU, from the culling record's bounds, the camera and the formula the culling pass uses,
//!   the coarsest level culling can pick for the instance this frame (within the limit made
//!   stricter by the hysteresis band, which the GPU's choice never goes below); the job skins the
//!   vertices of that level's list alone (the dispatch's rows are as wide as the largest job's
//!   list: a first version that skipped the other vertices one invocation at a time still cost
//!   lavapipe 119 of 258 ms a frame at 10,000 foxes), and the culling record names it as the finest level the
//!   instance may be drawn at (`drawable` in `shaders/cull.comp`: shadow views, which pick by
//!   their own scale, draw no finer). A job skins every vertex the first time, when its pose
//!   comes to rest ([`crate::scene::poses::REST_FRAMES`] frames unchanged, so that a pose at rest
//!   holds every vertex; the catch-up the frame after a change skins its level only, so a
//!   character the animation budget poses every few frames never skins whole; a first version
//!   skinned whole at the catch-up, which at 10,000 foxes posed every fourth frame skinned 4.4
//!   million vertices a frame on lavapipe, against 0.16 million with the catch-up at its level),
//!   after a structure woke from dormancy and must be refit from it, when its structure is refit
//!   this frame (a refit reads every vertex), and with levels of detail off or culling frozen. A
//!   vertex the last skinning left out gets no motion this frame (its previous position is set
//!   to its new one). Not covered: a ray that hits a far character between its refits reads the
//!   attributes of vertices skinned for another frame. `FrameSettings::skin_levels` turns it
//!   off (the sandbox's `--full-skinning`), and `counters.skinned_vertices` counts the vertices
//!   skinned.
//! - **One dispatch.** This frame's jobs (posed mesh, first joint matrix) and joint matrices
//!   (3×4, 48 bytes a joint) go up in one array with the scene's upload; one dispatch covers
//!   every job, a row of workgroups per job.
//! - **A crowd's poses on every core, copied once.** The ECS extraction sets a frame's poses in
//!   chunks on separate threads ([`PoseTable::chunks`]: each pose's matrices converted, its
//!   bounds found), and the upload writes the jobs and matrices straight into the staging memory
//!   ([`PoseTable::write_input`]). Before, one core converted 10,000 foxes' 240,000 matrices, and
//!   the 11.5 MB were copied three times more (into a word list, into the upload's own copy after
//!   comparing the two, into staging).
//! - **Morph targets** (blend shapes, glTF §3.7.2.2) are added first, in proportion to their
//!   weights (`MorphWeights`), then the joints move the result; a mesh with morph targets and no
//!   skin is posed the same way, with no joints.
//! - **Normals and tangents** are transformed by the cofactor of each vertex's blended matrix,
//!   so joints that scale unevenly still give perpendicular normals.
//! - **Bounds.** At load, every joint gets the rest-pose bounds of the vertices it moves; a
//!   pose's bounds are the union of those boxes moved by their joints (conservative and 24 box
//!   transforms for a fox, not a pass over its vertices), so culling follows the pose.
//! - **Acceleration structures.** A posed mesh's BLAS is refit after each skinning and rebuilt
//!   when the refits have degraded it ([`crate::accel`]); counters say how many.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::{BufferUse, Frame, PassKind};
use crate::layout::{GpuJointMatrix, GpuSkinJob, GpuSkinPush, GpuSkinVertex};
use crate::scene::gpu::GpuScene;
use crate::scene::poses::lod_pixels_per_error;
pub use crate::scene::poses::{PoseChunk, PoseChunks, PoseSet, PoseTable, joint_bounds, posed_bounds};
use crate::scene::{MeshId, SceneMirror};
use crate::settings::{FrameSettings, LOD_HYSTERESIS};
use crate::stats::FrameCounters;

/// Vertices a skinning workgroup handles.
const GROUP: u32 = 64;

impl GpuSkinVertex {
    /// Packs four joints and four weights (normalised to sum to 1 before quantising).
    pub fn new(joints: [u16; 4], weights: [f32; 4]) -> Self {
        let sum: f32 = weights.iter().map(|w| w.max(0.0)).sum();
        let w = if sum > 1e-6 { weights.map(|w| w.max(0.0) / sum) } else { [1.0, 0.0, 0.0, 0.0] };
        let unorm = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
        Self {
            joints01: joints[0] as u32 | (joints[1] as u32) << 16,
            joints23: joints[2] as u32 | (joints[3] as u32) << 16,
            weights01: unorm(w[0]) | unorm(w[1]) << 16,
            weights23: unorm(w[2]) | unorm(w[3]) << 16,
        }
    }

    /// The four joints.
    pub fn joints(&self) -> [u16; 4] {
        [self.joints01 as u16, (self.joints01 >> 16) as u16, self.joints23 as u16, (self.joints23 >> 16) as u16]
    }

    /// The four weights as the GPU reads them.
    pub fn weights(&self) -> [f32; 4] {
        let f = |x: u32| x as f32 / 65535.0;
        [f(self.weights01 & 0xFFFF), f(self.weights01 >> 16), f(self.weights23 & 0xFFFF), f(self.weights23 >> 16)]
    }
}

/// The skinning pass.
pub struct Skinning {
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    jobs: u32,
    groups: u32,
    palette_len: u32,
    /// By mesh id: refit this frame ([`Skinning::choose_levels`]'s scratch, cleared after use).
    refits: Vec<bool>,
    /// Posed meshes whose finest drawable level changed (scratch).
    changed: Vec<MeshId>,
}

impl Skinning {
    /// Creates the pass (a pipeline layout of its own: push constants only).
    pub fn new(ctx: &GpuContext) -> Result<Self, RenderError> {
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::COMPUTE,
            offset: 0,
            size: std::mem::size_of::<GpuSkinPush>() as u32,
        }];
        // SAFETY: valid create info pointing at locals; destroyed in `destroy`.
        let layout =
            unsafe { ctx.device.create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges), None) }?;
        let pipeline = match create_compute(ctx, layout, "skinning", shaders::SKINNING_COMP) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: never used.
                unsafe { ctx.destroying().destroy_pipeline_layout(layout, None) };
                return Err(e);
            }
        };
        Ok(Self { layout, pipeline, jobs: 0, groups: 0, palette_len: 0, refits: Vec::new(), changed: Vec::new() })
    }

    /// Before the scene's upload: collects the poses set since last frame into jobs, hands them
    /// to the upload and counts them.
    pub fn prepare(&mut self, mirror: &mut SceneMirror, scene: &mut GpuScene, counters: &mut FrameCounters) {
        let most = mirror.poses.take_jobs();
        self.jobs = mirror.poses.jobs().len() as u32;
        self.palette_len = mirror.poses.palette_len();
        self.groups = most.div_ceil(GROUP);
        scene.skin_input.set_len(if self.jobs > 0 { mirror.poses.input_words() } else { 0 });
        counters.skinned_meshes = self.jobs as u64;
        counters.skinned_vertices = mirror.poses.job_vertices();
    }

    /// After the acceleration structures chose this frame's refits (`refits`) and before the
    /// upload: how much of each job to skin. A job may skin only the vertices of the coarsest
    /// level the culling pass can pick for its instance this frame (the level within the
    /// limit made stricter by [`crate::settings::LOD_HYSTERESIS`], from the same bounds, camera
    /// and formula as the GPU's: it never picks finer), unless its structure is refit this frame
    /// (a refit reads every vertex), the camera used for culling is frozen, levels of detail are
    /// off, or `s.skin_levels` is off. Counts the vertices skinned.
    pub fn choose_levels(&mut self, mirror: &mut SceneMirror, s: &FrameSettings, refits: &[MeshId], counters: &mut FrameCounters) {
        if self.jobs == 0 {
            return;
        }
        let camera = *mirror.camera();
        let limit = s.lod_pixels * LOD_HYSTERESIS;
        let on = s.skin_levels && s.lod_pixels > 0.0 && !s.freeze_culling;
        for &id in refits {
            let i = id.0 as usize;
            if self.refits.len() <= i {
                self.refits.resize(i + 1, false);
            }
            self.refits[i] = true;
        }
        let refit = &self.refits;
        let most = mirror.set_skin_levels(
            |mesh, record, levels| match record {
                Some(r) if on && !refit.get(mesh.0 as usize).copied().unwrap_or(false) => {
                    levels.coarsest_within(lod_pixels_per_error(camera.view_proj, r.min, r.max, camera.viewport_size.y), limit)
                }
                _ => 0,
            },
            &mut self.changed,
        );
        for &id in refits {
            self.refits[id.0 as usize] = false;
        }
        // The dispatch's rows are as wide as the largest job's vertices (the level's own list).
        self.groups = most.div_ceil(GROUP);
        counters.skinned_vertices = mirror.poses.job_vertices();
    }

    /// After the upload: skins this frame's jobs into their posed meshes.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        if self.jobs == 0 {
            return Ok(());
        }
        let jobs = scene.skin_input.address();
        let palette = jobs + self.jobs as u64 * std::mem::size_of::<GpuSkinJob>() as u64;
        let push = GpuSkinPush {
            meshes: scene.mesh_table.address(),
            jobs,
            palette,
            weights: palette + self.palette_len as u64 * std::mem::size_of::<GpuJointMatrix>() as u64,
            job_count: self.jobs,
            groups: self.groups,
        };
        let (layout, pipeline, groups, count) = (self.layout, self.pipeline, self.groups, self.jobs);
        f.pass("skinning", PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(scene.res.meshes, BufferUse::Storage).record(
            |p| {
                // The push constants are this layout's; y and z split the jobs below the
                // guaranteed 65,535 groups.
                p.cmd.bind_pipeline(vk::PipelineBindPoint::COMPUTE, pipeline);
                p.cmd.push_constants(layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::bytes_of(&push));
                p.cmd.dispatch(groups, count.min(MAX_ROWS), count.div_ceil(MAX_ROWS));
            },
        )
    }

    /// Destroys the pass; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe {
            ctx.destroying().destroy_pipeline(self.pipeline, None);
            ctx.destroying().destroy_pipeline_layout(self.layout, None);
        }
    }
}

/// Jobs per row of the dispatch (the y extent every device supports).
pub const MAX_ROWS: u32 = 65_535;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_normalised_and_packed() {
        let v = GpuSkinVertex::new([1, 2, 3, 65535], [2.0, 1.0, 1.0, 0.0]);
        assert_eq!(v.joints(), [1, 2, 3, 65535]);
        let w = v.weights();
        assert!((w[0] - 0.5).abs() < 1e-4 && (w[1] - 0.25).abs() < 1e-4 && w[3] == 0.0, "{w:?}");
        assert_eq!(GpuSkinVertex::new([0; 4], [0.0; 4]).weights(), [1.0, 0.0, 0.0, 0.0], "no weight: the first joint");
    }
}
