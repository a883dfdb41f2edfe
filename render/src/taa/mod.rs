//! Temporal anti-aliasing (issue 27, item 2): each frame is rendered from a slightly different
//! sub-pixel position, and a resolve pass blends it with the history of earlier frames,
//! reprojected by the motion vectors (`crate::motion`), so every pixel gathers many samples over
//! time. Seed 000 §2.6 notes that deferred renderers cannot use MSAA and use temporal
//! anti-aliasing instead; the method is Karis's ("High Quality Temporal Supersampling",
//! SIGGRAPH 2014) with the usual refinements:
//!
//! - **Jitter**: the Halton (2, 3) sequence, 8 positions, added to the projection
//!   ([`crate::scene::SceneMirror::gpu_camera`]) so that every pass (rasterisation and the
//!   compute passes that rebuild positions from depth) sees the same jittered view.
//! - **Resolve** (`shaders/taa.comp`): history filtered by Catmull-Rom (a bilinear history
//!   blurs a little more each frame: the smearing of Bevy #10183), clipped in compressed YCoCg to
//!   the current 3×3 neighbourhood's variance box, and blended with 10 % of the current frame
//!   (more in motion, up to a third: each reprojection softens the history a little).
//!   Motion is taken from the nearest surface of the neighbourhood; the history is dropped where
//!   the reprojection leaves the screen or its depth shows a disocclusion.
//! - **History**: two targets that alternate (one read, one written); thrown away on the first
//!   frame, after a resize, a pipeline switch, or a camera cut
//!   ([`crate::scene::SceneMirror::cut_camera`]).
//! - **Output** (`shaders/taa_output.comp`): the resolved colour goes back into the HDR target,
//!   sharpened when asked, before bloom, auto-exposure and tone mapping; the history stays
//!   unsharpened.
//! - **What is special here**: a decal that appears or vanishes changes the neighbourhood at
//!   once, and the clipping follows it (no ghost of a despawned bullet hole); interlaced glass
//!   (odd rows) takes its motion and depth from the even rows behind it, and the composition
//!   has already filled every row, so jitter does not turn its rows into stripes; debug views
//!   are drawn unjittered and unresolved (the statistics then say `"aa": "none"`; one warning
//!   says why).

use ash::vk;
use glam::{Mat4, Vec2};

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{ScenePush, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::{HDR, MotionVectors, TAA_HISTORY_A, TAA_HISTORY_B};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind};
use crate::layout::{TAA_INTERLACED, TAA_RESET, TAA_SHARPEN_SHIFT};
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::{AntiAliasing, DebugView, FrameSettings, PipelineKind};

/// Positions of the jitter sequence before it repeats.
pub const JITTER_PHASES: u32 = 8;

/// Element `index` (from 1) of the Halton sequence in `base`: a low-discrepancy sequence in
/// [0, 1).
pub fn halton(mut index: u32, base: u32) -> f32 {
    let (mut result, mut f) = (0.0, 1.0);
    while index > 0 {
        f /= base as f32;
        result += f * (index % base) as f32;
        index /= base;
    }
    result
}

/// The sub-pixel offset of frame `frame` of the sequence, in pixels, within (−0.5, 0.5).
pub fn jitter_pixels(frame: u32) -> Vec2 {
    let i = frame % JITTER_PHASES + 1;
    Vec2::new(halton(i, 2), halton(i, 3)) - 0.5
}

/// Temporal anti-aliasing's passes and history.
pub struct Taa {
    /// The resolve, reading history A (writing B) and reading B (writing A).
    resolve: [vk::Pipeline; 2],
    /// The output pass after each.
    output: [vk::Pipeline; 2],
    /// Frames resolved (the jitter's phase).
    frame: u32,
    /// Which history is read this frame (false: A).
    read_b: bool,
    /// What the history was made with: the view size and the pipeline.
    made_with: Option<(vk::Extent2D, PipelineKind)>,
    /// The previous frame's unjittered view-projection.
    last_view_proj: Option<Mat4>,
    /// This frame: whether it runs, and whether the history is thrown away.
    runs: bool,
    reset: bool,
}

impl Taa {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self {
            resolve: [
                create_compute(ctx, layout, "taa", shaders::TAA_COMP)?,
                create_compute(ctx, layout, "taa", shaders::TAA_COMP_HISTORY_B)?,
            ],
            output: [
                create_compute(ctx, layout, "taa output", shaders::TAA_OUTPUT_COMP)?,
                create_compute(ctx, layout, "taa output", shaders::TAA_OUTPUT_COMP_HISTORY_B)?,
            ],
            frame: 0,
            read_b: false,
            made_with: None,
            last_view_proj: None,
            runs: false,
            reset: true,
        })
    }

    /// Once a frame, before the scene's upload: decides whether it runs and whether its history
    /// is kept, and sets the camera's jitter and previous view-projection. Returns whether it
    /// runs (the frame then draws motion vectors). `aa` is the anti-aliasing applied
    /// ([`AntiAliasing::applied`]).
    pub fn prepare(&mut self, mirror: &mut SceneMirror, s: &FrameSettings, aa: AntiAliasing, extent: vk::Extent2D) -> bool {
        let cut = mirror.take_camera_cut();
        self.runs = aa == AntiAliasing::Taa;
        // The frame count moves on (never 0, which says there is no accumulation) whenever
        // temporal anti-aliasing is asked for, also in the debug views it does not resolve: they
        // show each frame's samples of what it would average (soft shadows' rays).
        let asked = self.runs || s.aa.applied(s.pipeline, DebugView::Lit, u32::MAX) == AntiAliasing::Taa;
        if asked {
            self.frame = self.frame.wrapping_add(1).max(1);
        }
        if !self.runs {
            (self.made_with, self.last_view_proj) = (None, None);
            mirror.set_camera_temporal(Vec2::ZERO, None, if asked { self.frame } else { 0 });
            return false;
        }
        self.reset = cut || self.made_with != Some((extent, s.pipeline));
        self.made_with = Some((extent, s.pipeline));
        let jitter = jitter_pixels(self.frame) * 2.0 / Vec2::new(extent.width as f32, extent.height as f32);
        let prev = if self.reset { None } else { self.last_view_proj };
        mirror.set_camera_temporal(jitter, prev, self.frame);
        self.last_view_proj = Some(mirror.camera().view_proj);
        true
    }

    /// Whether it runs this frame.
    pub fn runs(&self) -> bool {
        self.runs
    }

    /// Resolves this frame's HDR image against the history and writes the result back into it,
    /// sharpened by `sharpen` (0–1), reprojecting by this frame's `motion` vectors (written
    /// whenever it runs). `interlaced`: odd rows held glass in depth this frame.
    pub fn record(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        motion: Option<MotionVectors>,
        interlaced: bool,
        sharpen: f32,
    ) -> Result<(), RenderError> {
        if !self.runs {
            return Ok(());
        }
        let Some(motion) = motion else {
            return Err(RenderError::Other("temporal anti-aliasing ran in a frame without motion vectors".into()));
        };
        let b = usize::from(self.read_b);
        let (history_in, history_out) = if self.read_b { (&TAA_HISTORY_B, &TAA_HISTORY_A) } else { (&TAA_HISTORY_A, &TAA_HISTORY_B) };
        let flags = if self.reset { TAA_RESET } else { 0 } | if interlaced { TAA_INTERLACED } else { 0 };
        let (resolve, output, extent) = (self.resolve[b], self.output[b], f.graph.extent());
        let groups = (extent.width.div_ceil(8), extent.height.div_ceil(8));
        f.pass("taa", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .sample(&HDR)
            .image(motion.target, ImageUse::StorageRead)
            .sample(history_in)
            .image(history_out, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, resolve, &ScenePush { texture_index: flags, ..p.push });
                p.cmd.dispatch(groups.0, groups.1, 1);
            })?;
        let word = ((sharpen.clamp(0.0, 1.0) * 65535.0).round() as u32) << TAA_SHARPEN_SHIFT;
        f.pass("taa_output", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .image(history_out, ImageUse::StorageRead)
            .image(&HDR, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, output, &ScenePush { texture_index: word, ..p.push });
                p.cmd.dispatch(groups.0, groups.1, 1);
            })?;
        self.read_b = !self.read_b;
        Ok(())
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in self.resolve.into_iter().chain(self.output) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_jitter_covers_the_pixel_evenly() {
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(2, 3), 2.0 / 3.0);
        let phases: Vec<Vec2> = (0..JITTER_PHASES).map(jitter_pixels).collect();
        assert!(phases.iter().all(|j| j.abs().max_element() < 0.5), "every offset inside the pixel");
        let mean = phases.iter().copied().sum::<Vec2>() / JITTER_PHASES as f32;
        assert!(mean.length() < 0.1, "the offsets centre on the pixel: {mean}");
        for quadrant in [Vec2::new(1.0, 1.0), Vec2::new(-1.0, 1.0), Vec2::new(1.0, -1.0), Vec2::new(-1.0, -1.0)] {
            assert!(phases.iter().any(|j| (*j * quadrant).cmpgt(Vec2::ZERO).all()), "a sample in quadrant {quadrant}");
        }
        assert_eq!(jitter_pixels(3), jitter_pixels(3 + JITTER_PHASES), "the sequence repeats");
    }
}
