//! Motion vectors: how far each pixel's surface moved on screen since the previous frame, for
//! temporal anti-aliasing (`crate::taa`; issue 27, item 1). None of the seeds treats them (seed
//! 000 §2.6 names temporal anti-aliasing as what deferred renderers use instead of MSAA); the
//! record follows the field's usual one (UV-space motion between unjittered projections, as in
//! Unreal's velocity buffer and Bevy's motion-vector prepass).
//!
//! **Design: work follows what moved.** Engines that write motion vectors draw *every* mesh a
//! second time (or add a target to every depth pass, in every pipeline). Here two passes, after
//! whichever pass wrote the opaque depth, serve all four pipelines:
//!
//! 1. **The camera's motion, from depth** (`shaders/motion_camera.comp`): each pixel's point is
//!    projected by this frame's and the previous frame's unjittered view-projections
//!    ([`crate::layout::GpuCamera::motion_view_proj`], `prev_view_proj`). This is exact for
//!    everything that did not move by itself, the sky included (a point at infinite depth is
//!    projected as a direction).
//!    Where the pipeline keeps each pixel's instance and triangle (the visibility buffer, and
//!    the deferred G-buffer for posed meshes), a posed mesh's skin motion is found here too, per
//!    pixel: the skinning pass keeps each vertex's previous position behind the posed vertices,
//!    and the pixel's barycentrics weigh its triangle's.
//! 2. **The movers** (`shaders/motion.vert`): only the instances whose transform changed since
//!    the previous upload (the mirror notes their previous transform as extraction writes the
//!    new one: [`crate::scene::Movers`]) and, in the forward pipelines, those whose posed mesh
//!    was skinned this frame are drawn, with depth EQUAL, over the camera's motion. One indirect
//!    multi-draw; a frame in which nothing moved draws nothing and uploads nothing for it.
//!
//! Drawing posed meshes again costs what drawing them cost: 10,000 animated foxes (all visible)
//! took 12.4 ms in the movers pass on the lent H100 against 22.4 ms for the G-buffer pass; found
//! per pixel from the ids, their motion costs the first pass a triangle fetch per skin pixel
//! (docs/experiments/aa-taa.md).
//!
//! Blended surfaces never write motion: glass does not replace the motion of what is behind it
//! (the ghosting of Godot #108664). The record (`shaders/include/motion.glsl`) also keeps the
//! surface's view depth in both frames, for temporal anti-aliasing's disocclusion test.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_compute, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, GBUFFER_LAYERS, HDR_FORMAT, MOTION, MotionVectors, VISIBILITY};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind};
use crate::scene::gpu::GpuScene;

/// Bytes of one indirect draw command (`GpuDrawCommand`).
const COMMAND_BYTES: u32 = std::mem::size_of::<crate::scene::GpuDrawCommand>() as u32;

/// Where the first pass finds each pixel's instance and triangle, for posed meshes' motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelIds {
    /// Nowhere (the forward pipelines' depth-only prepass): posed meshes are movers.
    None,
    /// The visibility buffer, or the forward pipelines' prepass when it writes ids.
    Visibility,
    /// The deferred G-buffer's layers (which name posed meshes' instances).
    GBuffer,
}

impl PixelIds {
    /// Where `pipeline` keeps them once its opaque depth is final; `forward_ids`: the forward
    /// pipelines' prepass writes ids this frame.
    pub fn of(pipeline: crate::settings::PipelineKind, forward_ids: bool) -> Self {
        match pipeline {
            crate::settings::PipelineKind::VisBuffer => PixelIds::Visibility,
            crate::settings::PipelineKind::Deferred => PixelIds::GBuffer,
            _ if forward_ids => PixelIds::Visibility,
            _ => PixelIds::None,
        }
    }
}

/// The motion-vector passes.
pub struct Motion {
    /// The camera's motion, by [`PixelIds`].
    camera: [vk::Pipeline; 3],
    movers: vk::Pipeline,
}

impl Motion {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let formats = [HDR_FORMAT];
        let movers = GraphicsDesc {
            name: "motion movers",
            vertex: shaders::MOTION_VERT,
            depth_compare: Some(vk::CompareOp::EQUAL),
            depth_write: false,
            ..GraphicsDesc::mesh("motion movers", Some(shaders::MOTION_FRAG), &formats, DEPTH_FORMAT)
        };
        Ok(Self {
            camera: [
                create_compute(ctx, layout, "motion camera", shaders::MOTION_CAMERA_COMP)?,
                create_compute(ctx, layout, "motion camera", shaders::MOTION_CAMERA_COMP_VISIBILITY)?,
                create_compute(ctx, layout, "motion camera", shaders::MOTION_CAMERA_COMP_GBUFFER)?,
            ],
            movers: create_graphics(ctx, layout, &movers)?,
        })
    }

    /// Writes this frame's motion vectors into the motion target: the camera's motion from the
    /// opaque depth (and posed meshes' from the pixels' `ids`), then the movers the scene's upload
    /// listed. Call once the opaque depth is final.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, ids: PixelIds) -> Result<MotionVectors, RenderError> {
        let (camera, extent) = (self.camera[ids as usize], f.graph.extent());
        f.pass("motion_camera", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .read(scene.res.meshes, BufferUse::Storage)
            .sample(&DEPTH)
            .when(ids == PixelIds::Visibility, |p| p.sample(&VISIBILITY))
            .when(ids == PixelIds::GBuffer, |p| p.sample(&GBUFFER_LAYERS))
            .image(&MOTION, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, camera, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
            })?;
        let written = MotionVectors { target: &MOTION };
        let (count, Some(pool)) = (scene.mover_count, scene.pool_buffer()) else { return Ok(written) };
        if count == 0 {
            return Ok(written);
        }
        let (movers, draws) = (self.movers, scene.mover_draws.buffer());
        f.pass("motion_movers", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTest)
            .color(&MOTION, Load::Keep)
            .reads(scene.res.drawn())
            // Posed meshes' previous positions, which the skinning pass wrote.
            .read(scene.res.meshes, BufferUse::Storage)
            .read(scene.res.tables, BufferUse::Indirect)
            .record(|p| {
                let push = p.push;
                p.bind_graphics(movers, &push);
                p.bind_mesh_pool(pool);
                // The draws (uploaded with the tables, declared above) live until the frame
                // completes.
                p.cmd.set_cull_mode(vk::CullModeFlags::NONE);
                // A count-draw, its count in the first command's place: on Mesa lavapipe 25 a
                // plain indirect draw recorded after a count-draw (the depth passes') took its
                // draw count from that earlier draw's count buffer.
                p.cmd.draw_indexed_indirect_count(draws, COMMAND_BYTES as u64, draws, 0, count, COMMAND_BYTES);
            })?;
        Ok(written)
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in self.camera.into_iter().chain([self.movers]) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
