//! Blended transparency (glTF `BLEND` materials: glass, visors, windows), seed 002
//! (`002_9638fcf4f713d316.txt`). Three ways, chosen by [`crate::settings::TransparencyMethod`]:
//!
//! - **Interlaced** ([`interlaced`], the deferred pipeline's default; §2.4.2, §3.1, §3.3): the
//!   nearest blended surface goes into the G-buffer on odd rows and is lit, shadowed and
//!   decalled like every other surface; a composition pass blends it over the opaque rows, with
//!   refraction checked by depth.
//! - **Depth peeling** ([`peeling`], deferred on request; §4.1.2): the full-resolution
//!   reference, two G-buffers each lit in full and composed with the same refraction.
//! - **Forward** (this module; every other pipeline, and deferred on request): §2.4.2's "opaque
//!   objects rendered using deferred techniques, followed by a forward renderer which draws
//!   transparent objects over the scene already illuminated".
//!
//! The forward way:
//! - **Opaque passes skip blended surfaces** ([`crate::scene::DrawItem::transparent`]): the depth
//!   prepass, the G-buffer and the visibility buffer hold the opaque scene only, so everything
//!   that reads them (light culling, shadows, decals, lighting) sees the surfaces behind the
//!   glass.
//! - **A transparency depth pass** writes the nearest transparent surface's depth into its own
//!   target, before light culling; culling widens each tile's depth range by it
//!   (`shaders/light_cull.comp`, variant `TRANSPARENT`), so the tile lists also hold the lights
//!   that reach only the glass in front of the opaque surfaces. Without that a light between
//!   a window and the wall behind it would light the wall but never the window.
//! - **A transparency pass** then draws the blended instances back to front
//!   ([`crate::scene::SceneMirror::sort_transparent`], one sort per frame by the distance to
//!   each instance's bounds centre), depth tested against the opaque depth and not writing it,
//!   with the forward shader's `TRANSPARENT` variant: the same material sampling and lighting
//!   over the same tile lists, alpha = the material's opacity, blended by Porter and Duff's
//!   "over" (seed 002 eq. 2.3, glTF's definition of `BLEND`): `C = α·Cs + (1 − α)·Cd`. Back
//!   faces are culled unless the material is double-sided, as for opaque surfaces. Every layer
//!   of glass is blended, where interlacing keeps the nearest.
//!
//! - **Shadows on the glass**: with shadows the shadow pass runs a second time, over the
//!   transparent depth, into a second layer of shadow words and tints (`ShadowInputs::glass`,
//!   `GLASS_SHADOWS`), and the transparency pass shades the nearest blended surface at each pixel
//!   with them: the same lights and shadows as the opaque surfaces. Glass behind that glass is lit
//!   unshadowed (a layer per pixel, like interlacing's single layer).
//!
//! What the forward way does not give the glass: the decal buffer belongs to the opaque surface
//! behind it, so decals land on it only with in-shader ray-query decals (the ray-query tier).
//! In every way glass casts coloured
//! shadows (`crate::shadows`), decals land on it only when a `DecalReceiver` says so
//! (extraction gives blended instances no receiver layers by default), and intersecting or
//! nested pieces of glass sort by instance, not per pixel. A frame without blended instances
//! records none of these passes and culls as before.

pub mod interlaced;
pub mod peeling;

use ash::vk;

use crate::RenderError;
use crate::culling::Draws;
use crate::decals::DecalFrame;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::pipeline::{Blend, GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{
    DEPTH, DEPTH_FORMAT, GBUFFER_MATERIAL, GBUFFER_NORMAL, HDR, HDR_FORMAT, TRANSPARENCY_SOURCE, TRANSPARENT_DEPTH,
};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassBuilder, PassKind, TargetDesc};
use crate::lights::{LightFrame, declare_light_reads};
use crate::scene::gpu::GpuScene;
use crate::settings::DecalMethod;
use interlaced::Interlaced;
use peeling::Peeling;

/// The transparency passes' pipelines.
pub struct TransparencyPasses {
    depth: vk::Pipeline,
    /// `[unshadowed, shadowed]`: the second reads the shadow pass's glass layer.
    shade: [vk::Pipeline; 2],
    /// With in-shader ray-query decals (ray-query tier only).
    shade_ray_query: Option<[vk::Pipeline; 2]>,
    /// The deferred pipeline's interlaced composition.
    pub interlaced: Interlaced,
    /// The deferred pipeline's depth-peeling composition.
    pub peeling: Peeling,
}

impl TransparencyPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let depth = GraphicsDesc::mesh("transparent depth", None, &[], DEPTH_FORMAT);
        let shade = |fragment| {
            let desc = GraphicsDesc {
                name: "transparency",
                fragment: Some(fragment),
                color_formats: &[HDR_FORMAT],
                depth_write: false,
                blend: Blend::Alpha,
                ..depth
            };
            create_graphics(ctx, layout, &desc)
        };
        Ok(Self {
            depth: create_graphics(ctx, layout, &depth)?,
            shade: [shade(shaders::FORWARD_FRAG_TRANSPARENT)?, shade(shaders::FORWARD_FRAG_SHADOWED_GLASS)?],
            shade_ray_query: if ctx.tier == Tier::RayQuery {
                Some([
                    shade(shaders::FORWARD_FRAG_TRANSPARENT_RAY_QUERY_DECALS)?,
                    shade(shaders::FORWARD_FRAG_SHADOWED_GLASS_RAY_QUERY_DECALS)?,
                ])
            } else {
                None
            },
            interlaced: Interlaced::new(ctx, layout)?,
            peeling: Peeling::new(ctx, layout)?,
        })
    }

    /// The transparency depth pass: the nearest depth of the instances in `order` (the frame's
    /// blended instances), for light culling. Records nothing when `order` is empty.
    pub fn depth(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, order: &[u32]) -> Result<(), RenderError> {
        if order.is_empty() {
            return Ok(());
        }
        f.pass("transparent_depth", PassKind::Graphics)
            .image(&TRANSPARENT_DEPTH, ImageUse::DepthWrite(Load::ClearDepth(0.0)))
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.depth, &push);
                draws.glass(p);
            })
    }

    /// The transparency pass: the instances in `order`, back to front, shaded and blended over
    /// the HDR target the pipeline's opaque shading wrote. Records nothing when `order` is empty.
    pub fn shade(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        order: &[u32],
        decals: &DecalFrame,
        lights: &LightFrame,
    ) -> Result<(), RenderError> {
        if order.is_empty() {
            return Ok(());
        }
        let shadowed = usize::from(lights.glass_shadows());
        let ray_query =
            self.shade_ray_query.filter(|_| decals.method == DecalMethod::RayQuery && decals.traced.is_some()).map(|p| p[shadowed]);
        let pass = f
            .pass("transparency", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTest)
            .color(&HDR, Load::Keep)
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .when(lights.glass_shadows(), |p| p.sample(&TRANSPARENT_DEPTH));
        let pass = match ray_query {
            Some(_) => pass.reads(decals.traced.into_iter().flatten().map(|a| (a, BufferUse::Accel))).reads(decals.ring_reads()),
            None => pass,
        };
        declare_light_reads(pass, lights).record(|p| {
            let push = p.push;
            p.bind_graphics(ray_query.unwrap_or(self.shade[shadowed]), &push);
            draws.glass(p);
        })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.depth].into_iter().chain(self.shade).chain(self.shade_ray_query.into_iter().flatten()) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.interlaced.destroy(ctx);
        self.peeling.destroy(ctx);
    }
}

/// A compute pass, `name`, running `pipeline` over every pixel (8×8 groups), reading and writing
/// what `declare` names.
fn compute_pass(
    f: &mut Frame,
    name: &'static str,
    pipeline: vk::Pipeline,
    declare: impl for<'f, 'a> FnOnce(PassBuilder<'f, 'a>) -> PassBuilder<'f, 'a>,
) -> Result<(), RenderError> {
    declare(f.pass(name, PassKind::Compute)).record(|p| {
        p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
        p.cmd.dispatch(p.extent.width.div_ceil(8), p.extent.height.div_ceil(8), 1);
    })
}

/// What a composition pass reads and writes: the kept lit image, the G-buffer's depth, material
/// (opacity, refraction) and normal, the scene tables; it rewrites the HDR target.
fn composition<'f, 'a>(pass: PassBuilder<'f, 'a>, scene: &GpuScene) -> PassBuilder<'f, 'a> {
    pass.sample(&TRANSPARENCY_SOURCE)
        .sample(&DEPTH)
        .sample(&GBUFFER_MATERIAL)
        .sample(&GBUFFER_NORMAL)
        .image(&HDR, ImageUse::StorageWrite)
        .read(scene.res.tables, BufferUse::Storage)
}

/// One transfer pass, `name`, copying the colour target `from` whole into `to` (same size and
/// format).
fn copy_target(f: &mut Frame, name: &'static str, from: &'static TargetDesc, to: &'static TargetDesc) -> Result<(), RenderError> {
    let (src, dst) = (f.graph.target(f.ctx, from)?, f.graph.target(f.ctx, to)?);
    let (src, dst) = (f.graph.raw(src), f.graph.raw(dst));
    f.pass(name, PassKind::Transfer).image(from, ImageUse::TransferSrc).image(to, ImageUse::TransferDst).record(|p| {
        let layers =
            vk::ImageSubresourceLayers { aspect_mask: vk::ImageAspectFlags::COLOR, mip_level: 0, base_array_layer: 0, layer_count: 1 };
        let region = vk::ImageCopy {
            src_subresource: layers,
            dst_subresource: layers,
            extent: vk::Extent3D { width: p.extent.width, height: p.extent.height, depth: 1 },
            ..Default::default()
        };
        // The graph put both images (same size and format) in the transfer layouts this names.
        p.cmd.copy_image(src, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, dst, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &[region]);
    })
}
