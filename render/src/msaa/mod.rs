//! Multisample anti-aliasing in the forward pipelines (issue: anti-aliasing, item 3). Seed 001's
//! introduction counts hardware anti-aliasing among the reasons to shade forward (Forward+), and
//! seed 000 §2.6 says deferred shading does not support MSAA and uses temporal anti-aliasing
//! instead: in the deferred pipelines MSAA applies as TAA ([`AntiAliasing::applied`]).
//!
//! **What is per sample and what per pixel.** The depth prepass rasterises depth (and the ids,
//! when the reflection rays, motion or a decal that must know the instance read them) at every
//! sample, and the shading pass tests
//! each sample against it: coverage, depth and therefore every edge are per sample, and the
//! shading pass resolves the mean of the samples into the HDR target. The shading itself runs
//! once per pixel and primitive (not per sample: the cost of MSAA stays near the cost of the
//! extra depth and colour bandwidth). Everything the frame computes from depth in screen space
//! is per pixel: the prepass resolves depth and ids to **sample 0** (so a pixel's depth and ids
//! always name one surface), and light culling, ray-traced shadows, ambient occlusion, the decal
//! pass, reflections and the hierarchical depth of occlusion culling work on that. A fragment of
//! another surface at an edge pixel would read inputs that are not its own; instead it reads them
//! at the nearest pixel (of the 3×3 around it) whose sample-0 depth is its own depth
//! (`shaders/include/msaa.glsl`): the pixel just beside the edge, on its own surface. That pixel's
//! tile also lists the lights for a depth range that holds the fragment.
//!
//! The sky fills the samples no geometry covered: the multisampled target is cleared with alpha
//! 0, shading writes alpha 1, so the resolved alpha is the covered fraction and the sky pass adds
//! its radiance × (1 − alpha) (`shaders/sky.comp`, COVERAGE). Glass is drawn after the resolve,
//! per pixel, depth-tested against sample 0 (as the reflections on it): its blend over the
//! resolved image needs no multisampled variant of every glass pipeline, and where an opaque edge
//! crosses glass the glass covers the whole pixel or none of it (its own edges are not
//! anti-aliased).
//!
//! **Reflections per sample.** Traced reflections are traced and resolved *before* the shading
//! pass, into a target of their own ([`crate::reflections::Reflections::record_before_shading`]),
//! and the shading pass adds that term to each sample from the pixel of the sample's surface, as
//! it reads the other per-pixel inputs. Added after the resolve, per pixel, the term of sample
//! 0's surface would go to every sample: at a mirror's silhouette the samples of the surface
//! behind got the mirror's reflection, or the mirror's own went without, a fringe a pixel wide
//! (docs/msaa_h100.png shows both). Screen-space reflections march the lit image, so they (and
//! the reflections' debug view) stay after the resolve, per pixel.
//!
//! Occlusion culling's depth pyramid is built from the resolved depth (sample 0): an object seen
//! only in other samples at a silhouette could be culled for that frame (not observed).
//!
//! Cost: on the lent H100 MSAA 4× adds 5.5 ms to the courtyard's frame (the depth prepass and
//! the shading pass grow with the samples; docs/experiments/aa-msaa.md), where TAA costs 0.17.
//!
//! The pipelines are made for one sample count; changing the count waits for the GPU once and
//! makes them again (with the multisampled targets), and switching MSAA off frees both.

use ash::vk;

use crate::gpu::device::GpuContext;
use crate::graph::FrameGraph;
use crate::settings::{AntiAliasing, FrameSettings};

/// MSAA's pipelines and the choice of the anti-aliasing a frame applies.
pub struct Msaa {
    /// The sample counts every attachment MSAA draws into can take on this device (bit `n`:
    /// `n` samples).
    supported: u32,
    /// The sample count in use (1 while MSAA is off).
    samples: u32,
    /// The fallbacks already logged: (asked for, applied).
    warned: Vec<(AntiAliasing, AntiAliasing)>,
}

impl Msaa {
    /// Reads what the device offers; makes no pipeline until MSAA is asked for.
    pub fn new(ctx: &GpuContext) -> Self {
        let limits = &ctx.limits;
        let mut counts = limits.framebuffer_color_sample_counts & limits.framebuffer_depth_sample_counts;
        if limits.standard_sample_locations == vk::FALSE {
            // Sample 0's place is known only where the locations are the standard ones.
            counts = vk::SampleCountFlags::TYPE_1;
        }
        // The ids attachment is an integer format, whose sample counts Vulkan 1.2 reports apart.
        // SAFETY: the physical device is valid; the query has no other precondition.
        let ids = unsafe {
            ctx.instance.get_physical_device_image_format_properties(
                ctx.physical,
                crate::graph::targets::VISIBILITY_FORMAT,
                vk::ImageType::TYPE_2D,
                vk::ImageTiling::OPTIMAL,
                vk::ImageUsageFlags::COLOR_ATTACHMENT,
                vk::ImageCreateFlags::empty(),
            )
        };
        counts &= ids.map_or(vk::SampleCountFlags::TYPE_1, |p| p.sample_counts);
        tracing::debug!(sample_counts = ?counts, "MSAA");
        Self { supported: counts.as_raw(), samples: 1, warned: Vec::new() }
    }

    /// The sample counts MSAA can use on this device (bit `n`: `n` samples).
    pub fn supported(&self) -> u32 {
        self.supported
    }

    /// The anti-aliasing `s` asks for as it applies ([`AntiAliasing::applied`]), saying once per
    /// kind of fallback that it fell back.
    pub fn choose(&mut self, s: &FrameSettings) -> AntiAliasing {
        let applied = s.aa.applied(s.pipeline, s.debug_view, self.supported);
        if applied != s.aa && !self.warned.contains(&(s.aa, applied)) {
            self.warned.push((s.aa, applied));
            tracing::warn!(
                asked = s.aa.name(),
                applied = applied.name(),
                pipeline = s.pipeline.name(),
                debug_view = ?s.debug_view,
                sample_counts = self.supported,
                "anti-aliasing falls back: MSAA runs in forward and Forward+ only, with the sample counts the device offers; \
                 temporal anti-aliasing is off under a debug view"
            );
        }
        applied
    }

    /// Sets the graph's multisampled targets for `aa`, before a frame is recorded. A change of
    /// sample count waits for the GPU and returns the new count: the frame's owner then remakes
    /// the forward passes for it (`crate::pipelines::forward::ForwardPasses::new`; none at 1).
    pub fn prepare(&mut self, ctx: &GpuContext, graph: &mut FrameGraph, aa: AntiAliasing) -> Option<u32> {
        let samples = aa.samples();
        if self.samples == samples {
            return None;
        }
        ctx.wait_idle();
        if samples > 1 {
            graph.set_samples(samples);
        } else {
            graph.drop_multisampled();
        }
        graph.destroy_retired(ctx);
        self.samples = samples;
        Some(samples)
    }

    /// Where the resolved depth of a pixel lies, as an offset from its centre in NDC for a view
    /// of `extent`: sample 0 of Vulkan's standard sample locations (zero without MSAA). Passes
    /// that rebuild positions from depth must rebuild them there, or a sloped surface rebuilt
    /// at the centre lies off itself by a fraction of a pixel's footprint, enough for its
    /// shadow and occlusion rays to hit it.
    pub fn depth_sample(samples: u32, extent: vk::Extent2D) -> glam::Vec2 {
        let sample_zero = match samples {
            2 => glam::Vec2::new(0.75, 0.75),
            4 => glam::Vec2::new(0.375, 0.125),
            8 => glam::Vec2::new(0.5625, 0.3125),
            _ => return glam::Vec2::ZERO,
        };
        // The viewport is flipped: rows go down, NDC y up.
        (sample_zero - 0.5) * glam::Vec2::new(2.0 / extent.width as f32, -2.0 / extent.height as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::Msaa;
    use ash::vk;
    use glam::Vec2;

    #[test]
    fn the_resolved_depth_lies_at_sample_zero_of_the_standard_locations() {
        let extent = vk::Extent2D { width: 200, height: 100 };
        // NDC spans 2 over the width (0.01 a pixel) and the height (0.02), y up while rows go down.
        let pixels = |samples| Msaa::depth_sample(samples, extent) * Vec2::new(100.0, -50.0);
        assert_eq!(pixels(1), Vec2::ZERO);
        assert!((pixels(2) - Vec2::new(0.25, 0.25)).length() < 1e-5, "{}", pixels(2));
        assert!((pixels(4) - Vec2::new(-0.125, -0.375)).length() < 1e-5, "{}", pixels(4));
        assert!((pixels(8) - Vec2::new(0.0625, -0.1875)).length() < 1e-5, "{}", pixels(8));
    }
}
