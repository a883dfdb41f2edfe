//! Stochastic direct lighting (issue 52, item 2; a first version): shadows for lists of many
//! lights at the cost of one shadow ray a pixel. Seed 001 traces a shadow ray per pixel for
//! every light of its tile (§4.3) and names that cost, and hard shadows, as its limits (§6);
//! this module samples instead of enumerating, drawing lights as ReSTIR streams its candidates
//! (weighted reservoir sampling: Bitterli et al. 2020, §3), and keeps the analytic
//! lighting noise-free with the ratio estimator of Heitz et al. 2018 ("Combining analytic direct
//! illumination and stochastic shadows").
//!
//! - **Which pixels sample.** Those whose light list holds more lights than
//!   `GpuLighting::sampled_lights_above`: [`DirectLight::exhaustive_up_to`] of the setting,
//!   which is every pixel with a light for [`DirectLight::Stochastic`], none for
//!   [`DirectLight::Exhaustive`], and those with more than 32 lights for [`DirectLight::Auto`]
//!   (none when the scene has no more lights than that: the frame is then exhaustive, as
//!   `"direct_light"` says, and the denoiser does not run).
//!   The shadow pass and shading compare the same list, so they agree pixel by pixel with no
//!   image between them. Only ray-traced shadows of tiled or every-light lists sample this way:
//!   the glass layer and shadow maps stay exhaustive.
//! - **Ray-query lights** have no list and no shadow pass: shading finds a pixel's lights and
//!   traces their rays itself. It samples there, inline (`shaders/include/ray_query_lights.glsl`):
//!   the first `sampled_lights_above` lights found get a ray each, the rest are summed
//!   unshadowed while one of them is drawn in proportion to its light (the whole BRDF's: the
//!   material is at hand), and one ray to it scales the sum. The pixel's own ratio, with no
//!   denoiser: the frame's [`LightFrame::samples`](super::LightFrame::samples) stays false. On
//!   the ray-tracing-pipeline tier the lights are found by an any-hit shader, which offers each
//!   to the draw but cannot trace, so there every light found is drawn from (`stochastic` as
//!   applied) and the ray-generation shader traces the one ray
//!   (`shaders/include/ray_pipeline_lights.glsl`).
//! - **Drawing** (`shaders/include/direct_sampling.glsl`, in the shadow pass). A pixel weighs
//!   the lights of its list by their unshadowed light at the point, draws one in proportion by
//!   weighted reservoir sampling (one pass, no table), and traces one ray
//!   to a point of that light's shape (its size: soft shadows, `shadow_ray_sampled`). It writes
//!   the light the ray let through (V) and the list's unshadowed light S ([`SHADOW_SAMPLES`]).
//!   - **The weights.** Deferred shading writes its G-buffer before its shadows, so there the
//!     pass reads the material and weighs each light by what it reflects towards the eye
//!     through the whole BRDF, specular lobe included (the `SHADOW_MATERIAL` variant): the
//!     ratio then lets through each light's share of what shading sums. Forward and the
//!     visibility buffer trace their shadows from depth alone, before any material is known,
//!     and weigh the light a diffuse surface receives. On a metal floor whose highlight a bar
//!     shadows, the diffuse weights let half the highlight through (the lavapipe test
//!     `sampled_shadows_weigh_a_glossy_floor_through_its_brdf_in_deferred_shading`: blocks
//!     0.29 off a ray per light on average, 0.0069 with the BRDF's weights, where the shadows
//!     change them by 0.48). The BRDF costs deferred's shadow pass 0.15 ms at 28,587 lights on
//!     the H200 (1.09 → 1.24 ms).
//!   - Lists of up to 64 lights are drawn from whole: S is exact and V an unbiased estimate of
//!     the share that gets through, so its averages are too.
//!   - Longer lists give one candidate from each of 64 equal strata (a random offset, new each
//!     frame): S is then an unbiased estimate and V a ratio of two random sums, biased dark by
//!     a share that shrinks as the candidates grow. The first version drew eight candidates for
//!     every list: 27 % too dark at a test pixel whose lights were 2 % shadowed. With 64, at
//!     455 lights a tile, the H200 pictures of `--bench-scene many-lights` match the
//!     exhaustive ones by eye, and the test's lists of over 64 lights are within 16 % of the
//!     shadows' effect on average (21 % at most).
//! - **Denoising** (`shaders/shadow_denoise.comp`, [`ShadowSampling::record`]): per pixel,
//!   ΣSV / ΣS over a 3×3 neighbourhood weighted towards the pixel's tangent plane, into
//!   [`SHADOW_RATIO`].
//! - **Shading** (`shade_surface`): a sampling pixel sums its lights unshadowed (the same loop
//!   as exhaustive shading) and multiplies the sum by the ratio. Its noise is the ratio's only:
//!   what is unshadowed stays exact. With tiled lights the draws change every frame (they hash
//!   a frame count light culling keeps on the GPU, so nothing is uploaded for it): temporal
//!   anti-aliasing's history averages them where it runs; without it the sampled shadows
//!   shimmer. With every-light lists they change with temporal anti-aliasing's frame count,
//!   and stay put without it.
//! - **Suns apart.** A sampling pixel traces one ray to each of the first four directional
//!   lights as well ([`Suns`], its first shadow word holds their bits) and samples only the
//!   rest: a sun is in every list and often the strongest light, so among 455 lights a tile it
//!   was drawn by few pixels, which it then lit brightly: grain no 3×3 neighbourhood averaged
//!   out (`--bench-scene many-lights`, the wall's shadow from the sun).
//!
//! **What this version leaves out** (issue 52 asks for them): reservoirs reused across frames
//! along the motion vectors and between neighbours (here each pixel's draw is new every frame
//! and only the ratio is shared spatially), a denoiser with its own history, and the material's
//! specular lobe in the target function of forward shading and the visibility buffer (their
//! ratio is that of a diffuse surface's light, applied to the whole BRDF: their shadow pass
//! runs before any material is known; the visibility buffer's would have to rebuild it from
//! the triangle, as its shading does). Temporal reuse was built and measured (`docs/experiments/
//! direct-light-temporal-reuse.md`): under temporal anti-aliasing the long lists' bias it removes
//! was below the run-to-run noise of 16 frames, so it was not merged.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, SHADOW_RATIO, SHADOW_SAMPLES};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind, ResourceId};
use crate::layout::{DIRECT_LIGHT_SUNS, LIGHT_DIRECTIONAL, LIGHT_DISK, LIGHT_RECT};
use crate::scene::gpu::GpuScene;
use crate::scene::{GpuLight, SlotTable};
use crate::settings::{DirectLight, ShadowMethod};

/// The directional lights a sampling pixel traces a ray to each (`GpuLighting::suns`): the first
/// [`DIRECT_LIGHT_SUNS`] in slot order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Suns {
    /// Their slots (the first `count`).
    pub slots: [u32; DIRECT_LIGHT_SUNS as usize],
    /// How many there are.
    pub count: u32,
}

/// Finds the [`Suns`], and whether any light is an area light (the shading passes then use their
/// pipelines with the area lights' code, `crate::gpu::pipeline::Specialization`), when the light
/// table changed since the last search, and keeps them otherwise: a frame whose lights are
/// still costs a comparison. Called every frame, sampled or not, so that no change slips by
/// between two frames that sample.
#[derive(Debug, Default)]
pub struct LightSearch {
    found: Option<Suns>,
    area_lights: bool,
    /// The table's slot count at the last search (a trim drops the dirty marks of the slots it
    /// drops, a sun's among them).
    slots: u32,
}

impl LightSearch {
    /// The directional lights of `lights`, searched again (with the area lights) when a light
    /// was written or released since the last upload, when the table's slot count changed, or
    /// before the first search.
    pub fn find(&mut self, lights: &SlotTable<GpuLight>) -> Suns {
        if lights.dirty_count() > 0 || lights.slot_count() != self.slots || self.found.is_none() {
            self.slots = lights.slot_count();
            let mut suns = Suns::default();
            self.area_lights = false;
            for (slot, light) in lights.records().iter().enumerate() {
                match light.kind {
                    LIGHT_DIRECTIONAL if suns.count < DIRECT_LIGHT_SUNS => {
                        suns.slots[suns.count as usize] = slot as u32;
                        suns.count += 1;
                    }
                    LIGHT_RECT | LIGHT_DISK => self.area_lights = true,
                    _ => {}
                }
            }
            self.found = Some(suns);
        }
        self.found.unwrap_or_default()
    }

    /// Whether a light of the last search ([`LightSearch::find`]) is a rect or disk light.
    pub fn area_lights(&self) -> bool {
        self.area_lights
    }
}

/// The sampled shadows' denoiser.
pub struct ShadowSampling {
    denoise: vk::Pipeline,
}

/// The list length above which a pixel samples its lights' shadows this frame
/// (`GpuLighting::sampled_lights_above`; `u32::MAX`: none samples): only ray-traced shadows
/// sample (of a pixel's light list, or of the lights the ray-query lights find while shading),
/// and none when the scene's live `lights` are no more than the method traces a ray each for:
/// no pixel can find more, so the frame is exhaustive and the denoiser does not run (the peer
/// scene's 28 lights under `auto`).
pub fn sampled_lights_above(direct: DirectLight, shadows: ShadowMethod, lights: u32) -> u32 {
    match shadows {
        ShadowMethod::RayQuery | ShadowMethod::RayPipeline if lights > direct.exhaustive_up_to() => direct.exhaustive_up_to(),
        _ => u32::MAX,
    }
}

/// The method a frame applied, for statistics: `None` without ray-traced shadows.
pub fn applied(sampled_lights_above: u32, traced: bool) -> Option<DirectLight> {
    traced.then_some(match sampled_lights_above {
        u32::MAX => DirectLight::Exhaustive,
        0 => DirectLight::Stochastic,
        _ => DirectLight::Auto,
    })
}

impl ShadowSampling {
    /// Creates the denoiser's pipeline.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self { denoise: create_compute(ctx, layout, "sampled shadows' denoiser", shaders::SHADOW_DENOISE_COMP)? })
    }

    /// Records the denoiser, after the shadow pass wrote [`SHADOW_SAMPLES`] over this frame's
    /// depth; shading then reads [`SHADOW_RATIO`] (`crate::lights::declare_light_reads`). It
    /// reads the light tiles (`light_tiles`, when lights are tiled) to skip the pixels that did
    /// not sample.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, light_tiles: Option<ResourceId>) -> Result<(), RenderError> {
        let extent = f.graph.extent();
        f.pass("shadow_denoise", PassKind::Compute)
            .sample(&DEPTH)
            .reads(scene.res.shaded())
            .reads(light_tiles.map(|t| (t, BufferUse::Storage)))
            .image(&SHADOW_SAMPLES, ImageUse::StorageRead)
            .image(&SHADOW_RATIO, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, self.denoise, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
            })
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle (or the pipeline was never used).
        unsafe { ctx.destroying().destroy_pipeline(self.denoise, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suns_are_found_again_when_lights_change() {
        let light = |kind| GpuLight { kind, ..bytemuck::Zeroable::zeroed() };
        let mut table = SlotTable::default();
        table.insert(light(crate::layout::LIGHT_POINT));
        let sun = table.insert(light(LIGHT_DIRECTIONAL));
        let mut search = LightSearch::default();
        assert_eq!(search.find(&table), Suns { slots: [sun, 0, 0, 0], count: 1 });
        table.take_dirty(|_, _| {});
        for _ in 0..5 {
            table.insert(light(LIGHT_DIRECTIONAL));
        }
        // Drained before the search (as if uploaded unsearched): the slot count still tells.
        table.take_dirty(|_, _| {});
        let found = search.find(&table);
        assert_eq!(found.count, DIRECT_LIGHT_SUNS, "at most this many are traced apart");
        assert_eq!(found.slots, [1, 2, 3, 4]);
        // A sun in the last slot, removed and trimmed away in one frame: no dirty mark is left,
        // but the slot count fell.
        table.take_dirty(|_, _| {});
        let last = table.slot_count() - 1;
        table.remove(last);
        table.trim();
        assert_eq!(table.dirty_count(), 0, "the trim dropped the removed slot's mark");
        assert_eq!(search.find(&table).slots, [1, 2, 3, 4]);
        for slot in 1..table.slot_count() {
            table.remove(slot);
        }
        table.trim();
        table.take_dirty(|_, _| {});
        assert_eq!(search.find(&table), Suns { slots: [0; 4], count: 0 }, "the removed suns are forgotten");
        assert!(!search.area_lights());
    }

    #[test]
    fn area_lights_are_found_when_written_and_forgotten_when_released() {
        let light = |kind| GpuLight { kind, ..bytemuck::Zeroable::zeroed() };
        let mut table = SlotTable::default();
        let point = table.insert(light(crate::layout::LIGHT_POINT));
        let mut search = LightSearch::default();
        search.find(&table);
        assert!(!search.area_lights(), "a point light is no area light");
        table.take_dirty(|_, _| {});
        // A light that becomes a disk in its own slot (same slot count): its dirty mark tells.
        table.write(point, light(LIGHT_DISK));
        search.find(&table);
        assert!(search.area_lights(), "the disk is found");
        table.take_dirty(|_, _| {});
        let rect = table.insert(light(LIGHT_RECT));
        table.write(point, light(crate::layout::LIGHT_POINT));
        search.find(&table);
        assert!(search.area_lights(), "the rectangle is found");
        table.take_dirty(|_, _| {});
        search.find(&table);
        assert!(search.area_lights(), "a still frame keeps what was found");
        table.remove(rect);
        search.find(&table);
        assert!(!search.area_lights(), "the released rectangle is forgotten");
    }

    #[test]
    fn only_ray_traced_shadows_sample() {
        for shadows in [ShadowMethod::RayQuery, ShadowMethod::RayPipeline] {
            assert_eq!(sampled_lights_above(DirectLight::Stochastic, shadows, 1000), 0);
            assert_eq!(sampled_lights_above(DirectLight::Auto, shadows, 1000), DirectLight::AUTO_EXHAUSTIVE_UP_TO);
            assert_eq!(sampled_lights_above(DirectLight::Exhaustive, shadows, 1000), u32::MAX);
            // No list can be longer than the scene's lights.
            let few = DirectLight::AUTO_EXHAUSTIVE_UP_TO;
            assert_eq!(sampled_lights_above(DirectLight::Auto, shadows, few), u32::MAX, "auto with few lights");
            assert_eq!(sampled_lights_above(DirectLight::Auto, shadows, few + 1), few);
            assert_eq!(sampled_lights_above(DirectLight::Stochastic, shadows, 1), 0);
            assert_eq!(sampled_lights_above(DirectLight::Stochastic, shadows, 0), u32::MAX, "no light");
        }
        for shadows in [ShadowMethod::Maps, ShadowMethod::None] {
            assert_eq!(sampled_lights_above(DirectLight::Stochastic, shadows, 1000), u32::MAX);
        }
        assert_eq!(applied(0, true), Some(DirectLight::Stochastic));
        assert_eq!(applied(32, true), Some(DirectLight::Auto));
        assert_eq!(applied(u32::MAX, true), Some(DirectLight::Exhaustive));
        assert_eq!(applied(0, false), None);
    }
}
