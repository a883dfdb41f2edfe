//! Physically based bloom: light spreading around the bright parts of the image as it does in a
//! lens, after Jimenez's "Next Generation Post Processing in Call of Duty: Advanced Warfare"
//! (SIGGRAPH 2014), which Unreal, Unity HDRP and Bevy also follow. None of the seeds treats
//! post-processing; seed 000 §2.3 names the HDR target this reads.
//!
//! Compute passes over a pyramid in one buffer (`shaders/include/bloom.glsl`), after everything
//! that lights the HDR target (glass and reflections included) and before tone mapping:
//!
//! 1. **Down**: level 0 at half resolution from the HDR target, then each level at half the one
//!    above, by the 13-tap filter (a centre box and four corner boxes). The first downsample
//!    weights each box by 1 / (1 + luma), Karis's average: a lone bright pixel cannot bloom into a
//!    blob that flashes as it comes and goes (under jitter, O3DE #1161).
//! 2. **Up**: from the smallest level back to level 0, each adds the level below it, upsampled by
//!    a 3×3 tent.
//! 3. **Composite**: the HDR target becomes `mix(image, bloom, intensity)`, where bloom is level 0
//!    divided by the level count. Every filter's weights sum to one, so the blurred copy carries
//!    the image's energy and the blend keeps it: no threshold, no light added (tested within 2 %
//!    on a lit scene; Karis's average takes energy from lone bright pixels by design).
//!
//! **Why a buffer, not a mip chain.** The graph's render targets have the view's size and one
//! level; the pyramid is sized from the viewport in the shader, like culling's depth pyramid, and
//! the buffer is replaced only when the view is resized, so a steady frame allocates nothing.
//! Filtering between texels is done in the shader (four loads a bilinear tap).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::pipeline::{ScenePush, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::HDR;
use crate::graph::{BufferUse, Frame, FrameGraph, ImageUse, PassContext, PassKind, ResourceId};
use crate::layout::BLOOM_MAX_LEVELS;
use crate::scene::gpu::GpuScene;
use crate::settings::BloomSettings;

/// Levels of the pyramid for a viewport of `extent`: down to about 8 texels on the short side,
/// at most [`BLOOM_MAX_LEVELS`], at least one.
pub fn bloom_levels(extent: vk::Extent2D) -> u32 {
    let short = extent.width.min(extent.height).max(1);
    (short.ilog2().saturating_sub(3)).clamp(1, BLOOM_MAX_LEVELS)
}

/// The size of level `level` (level 0 at half the viewport's).
fn level_size(extent: vk::Extent2D, level: u32) -> (u32, u32) {
    ((extent.width >> (level + 1)).max(1), (extent.height >> (level + 1)).max(1))
}

/// Bytes of the pyramid for `extent` (8 a texel).
fn pyramid_bytes(extent: vk::Extent2D) -> u64 {
    (0..bloom_levels(extent)).map(|l| level_size(extent, l)).map(|(w, h)| w as u64 * h as u64 * 8).sum()
}

/// The bloom passes and their pyramid.
pub struct Bloom {
    first: vk::Pipeline,
    down: vk::Pipeline,
    up: vk::Pipeline,
    composite: vk::Pipeline,
    /// The pyramid and the extent it was made for.
    pyramid: Option<(Buffer, vk::Extent2D)>,
    res: ResourceId,
    runs: bool,
}

impl Bloom {
    /// Creates the pipelines; the pyramid is made on the first frame with bloom.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let compute = |name, spirv| create_compute(ctx, layout, name, spirv);
        Ok(Self {
            first: compute("bloom first downsample", shaders::BLOOM_COMP_FIRST)?,
            down: compute("bloom downsample", shaders::BLOOM_COMP_DOWN)?,
            up: compute("bloom upsample", shaders::BLOOM_COMP_UP)?,
            composite: compute("bloom composite", shaders::BLOOM_COMP)?,
            pyramid: None,
            res: graph.resource("bloom pyramid"),
            runs: false,
        })
    }

    /// Makes the pyramid for this frame's extent when bloom runs (replacing one of another size)
    /// and sets the lighting record's bloom fields; before the scene's upload.
    pub fn prepare(&mut self, f: &mut Frame, scene: &mut GpuScene, settings: BloomSettings) -> Result<(), RenderError> {
        self.runs = settings.runs();
        if !self.runs {
            scene.set_bloom(0, 0, 0.0);
            return Ok(());
        }
        let extent = f.graph.extent();
        if self.pyramid.as_ref().is_none_or(|(_, e)| *e != extent) {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
            let buffer = Buffer::new(f.ctx, "bloom pyramid", pyramid_bytes(extent), usage, MemoryLocation::GpuOnly)?;
            if let Some((old, _)) = self.pyramid.replace((buffer, extent)) {
                f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old));
            }
        }
        let address = self.pyramid.as_ref().map_or(0, |(b, _)| b.address);
        scene.set_bloom(address, bloom_levels(extent), settings.intensity.min(1.0));
        Ok(())
    }

    /// Records the passes (nothing when bloom is off): the downsamples, the upsamples and the
    /// composite into the HDR target.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        if !self.runs {
            return Ok(());
        }
        let extent = f.graph.extent();
        let levels = bloom_levels(extent);
        let groups = |(w, h): (u32, u32)| (w.div_ceil(8), h.div_ceil(8));
        let res = self.res;
        let dispatch = |p: &PassContext, level: u32| {
            p.set_push(&ScenePush { texture_index: level, ..p.push });
            let (x, y) = groups(level_size(extent, level));
            p.cmd.dispatch(x, y, 1);
        };
        // Each chain is one pass (its steps ordered inside it): a pass a level cost the CPU its
        // timestamps, barriers and binds 13 times a frame at 1080p.
        let (first, down, up) = (self.first, self.down, self.up);
        f.pass("bloom_down", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .sample(&HDR)
            .write(res, BufferUse::Storage)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, first, &p.push);
                dispatch(p, 0);
                p.bind(vk::PipelineBindPoint::COMPUTE, down, &p.push);
                for level in 1..levels {
                    p.compute_to_compute();
                    dispatch(p, level);
                }
            })?;
        if levels > 1 {
            f.pass("bloom_up", PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(res, BufferUse::Storage).record(
                |p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, up, &p.push);
                    for (i, level) in (0..levels - 1).rev().enumerate() {
                        if i > 0 {
                            p.compute_to_compute();
                        }
                        dispatch(p, level);
                    }
                },
            )?;
        }
        let pipeline = self.composite;
        f.pass("bloom_composite", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .read(res, BufferUse::Storage)
            .image(&HDR, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                let (x, y) = groups((extent.width, extent.height));
                p.cmd.dispatch(x, y, 1);
            })
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(mut self, ctx: &GpuContext) {
        for p in [self.first, self.down, self.up, self.composite] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some((b, _)) = self.pyramid.take() {
            b.destroy(ctx);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pyramid_stops_near_eight_texels_and_holds_every_level() {
        let e = |width, height| vk::Extent2D { width, height };
        assert_eq!(bloom_levels(e(1920, 1080)), 7);
        assert_eq!(bloom_levels(e(320, 240)), 4);
        assert_eq!(bloom_levels(e(16, 16)), 1);
        assert_eq!(bloom_levels(e(1, 1)), 1);
        assert_eq!(level_size(e(1920, 1080), 0), (960, 540));
        assert_eq!(level_size(e(1920, 1080), 6), (15, 8));
        assert_eq!(pyramid_bytes(e(4, 2)), 16, "one level of 2×1 texels, 8 bytes each");
    }
}
