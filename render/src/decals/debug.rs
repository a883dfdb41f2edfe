//! Debug view of decals: every live decal's oriented box (green) and the AABB the acceleration
//! structure holds for it (yellow), drawn as lines over the HDR image, on top of everything.
//! (The per-pixel heat map of decals tested is a debug view of the shading pass instead:
//! `DebugView::DecalHeatmap`.)

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, ScenePush, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{HDR, HDR_FORMAT};
use crate::graph::{BufferUse, Frame, Load, PassKind};
use crate::scene::gpu::GpuScene;

/// The box-drawing pass.
pub struct DecalBoxes {
    pipeline: vk::Pipeline,
}

impl DecalBoxes {
    /// Creates the line pipeline.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let formats = [HDR_FORMAT];
        let desc = GraphicsDesc {
            name: "decal boxes",
            vertex: shaders::DECAL_BOXES_VERT,
            fragment: Some(shaders::FLAT_COLOR_FRAG),
            mesh_vertices: false,
            color_formats: &formats,
            depth_format: None,
            depth_compare: None,
            depth_write: false,
            topology: vk::PrimitiveTopology::LINE_LIST,
            blend: crate::gpu::pipeline::Blend::Replace,
            write_masks: &[],
            samples: 1,
        };
        Ok(Self { pipeline: create_graphics(ctx, layout, &desc)? })
    }

    /// Draws the boxes of the `live` decals (the first `live` entries of the dense box table) over
    /// the HDR target.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, live: u32) -> Result<(), RenderError> {
        if live == 0 {
            return Ok(());
        }
        f.pass("decal_boxes", PassKind::Graphics).color(&HDR, Load::Keep).read(scene.res.tables, BufferUse::Storage).record(|p| {
            for mode in [0u32 /* oriented */, 1 /* AABB */] {
                let push = ScenePush { texture_index: mode, ..p.push };
                p.bind_graphics(self.pipeline, &push);
                p.cmd.draw(24, live, 0, 0);
            }
        })
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_pipeline(self.pipeline, None) };
    }
}
