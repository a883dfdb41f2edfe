//! Shadow maps for devices without ray tracing (issue 12 item 5), with seed 002's coloured
//! shadows (`../shared/seeds/002`, §3.2.1, eqs. 3.1–3.2, Table 3.3), feeding the same
//! visibility input as the ray-traced shadow pass: the shadow bits and tints that every
//! pipeline's shading reads.
//!
//! - **Views** ([`plan_views`], on the CPU, uploaded only when they change): a spot light gets
//!   one perspective view over its cone, a point light six cube faces, a directional light one
//!   orthographic view fitted to the camera's view up to
//!   [`ShadowMapBudget::directional_distance`] (a bounding sphere of that slice of the view
//!   frustum, so the map's size does not change as the camera turns, and its position snapped
//!   to whole texels, so its edges do not crawl as the camera moves). Lights take views in slot
//!   order until the atlas is full; the rest are unshadowed and counted.
//! - **The atlas**: one depth target and one filter target (RGBA8), a tile per view, drawn in
//!   one pass (`shaders/shadow_map.vert`, `shadow_map.frag`): per tile, a viewport and the
//!   instances inside that view's frustum (one indirect draw of the list `crate::culling`
//!   made for the view), both faces. With coloured shadows glass writes its colour and opacity on odd rows
//!   only (the seed's interlaced shadow map: a single pass over the geometry keeps both the
//!   glass and the opaque surface behind it).
//! - **The resolve** (`shaders/shadows_mapped.comp`): the shadow pass's per-pixel loop
//!   (`shadow_pass.glsl`), each ray replaced by a lookup of two texels, the point's and its
//!   pair row's (`shadow_maps.glsl`): the more opaque is the occluder, the other the glass
//!   (eq. 3.1). Towards a light with a size the sampled ray is marched through the maps instead
//!   (soft shadows: `docs/lights-and-shadows.md`). The glass filters light by colour ×
//!   (1 − opacity), as the traced any-hit does,
//!   rather than the seed's `min(I_L, C)` (eq. 3.2): the same for white light, and the tiers
//!   agree.
//!
//! Why one resolve pass instead of the seed's lighting pass per light: every pipeline here
//! shades all of a pixel's lights in one pass from the shadow bits, so the maps answer the same
//! question the rays do, and shading does not know which answered. Left out: filtering (a
//! light without a size casts hard shadows, as with rays), caching maps of lights and casters that did not
//! move (every map is drawn every frame), occlusion culling of casters per view, and cascades (one fitted
//! map per directional light).

use ash::vk;
use glam::{Mat4, Vec3, Vec4Swizzles};

use crate::RenderError;
use crate::culling::Draws;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_computes, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{
    DEPTH, DEPTH_FORMAT, SHADOW_DEBUG, SHADOW_MAP_DEPTH, SHADOW_MAP_FILTER, SHADOW_MAP_FILTER_FORMAT, TRANSPARENT_DEPTH,
};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind};
use crate::layout::{GpuCamera, GpuLight, GpuShadowView, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, NO_SHADOW_MAP, SHADOW_VIEWS_HEADER};
use crate::scene::gpu::GpuScene;
use crate::settings::ShadowMapBudget;
use crate::shadows::ShadowInputs;

/// Near plane of spot and point lights' views, in metres.
const NEAR: f32 = 0.05;
/// How far behind the directional view's sphere (towards the light) casters are still drawn.
const CASTER_REACH: f32 = 100.0;
/// Far plane of lights without a range.
const FAR_UNBOUNDED: f32 = 1000.0;

/// What [`plan_views`] decided for a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadowMapPlan {
    /// Views (atlas tiles) drawn.
    pub views: u32,
    /// Lights left without a shadow map (the atlas was full).
    pub missing: u32,
}

/// The shadow-map passes and the atlas's layout.
pub struct ShadowMaps {
    raster: vk::Pipeline,
    /// `[depth target, glass layer]` (`ShadowInputs::glass`).
    resolve: [vk::Pipeline; 2],
    budget: ShadowMapBudget,
    columns: u32,
    rows: u32,
    /// The views buffer's words, rebuilt each frame into the same vector.
    words: Vec<u32>,
}

impl ShadowMaps {
    /// Creates the passes; the atlas waits for the first frame that uses it.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, budget: ShadowMapBudget) -> Result<Self, RenderError> {
        let budget = ShadowMapBudget { tile: budget.tile.clamp(16, 8192) & !1, tiles: budget.tiles.max(1), ..budget };
        let max = ctx.limits.max_image_dimension2_d;
        let columns = (budget.tiles as f32).sqrt().ceil() as u32;
        let rows = budget.tiles.div_ceil(columns);
        if columns * budget.tile > max || rows * budget.tile > max {
            return Err(RenderError::Other(format!(
                "a shadow-map atlas of {} tiles of {}² texels ({}×{}) is larger than this device's images ({max})",
                budget.tiles,
                budget.tile,
                columns * budget.tile,
                rows * budget.tile
            )));
        }
        let desc = GraphicsDesc {
            vertex: shaders::SHADOW_MAP_VERT,
            ..GraphicsDesc::mesh("shadow maps", Some(shaders::SHADOW_MAP_FRAG), &[SHADOW_MAP_FILTER_FORMAT], DEPTH_FORMAT)
        };
        let raster = create_graphics(ctx, layout, &desc)?;
        let stages = [("shadows (maps)", shaders::SHADOWS_MAPPED_COMP), ("glass shadows (maps)", shaders::SHADOWS_MAPPED_COMP_GLASS_LAYER)];
        let resolve = create_computes(ctx, layout, stages).inspect_err(|_| {
            // SAFETY: never used.
            unsafe { ctx.destroying().destroy_pipeline(raster, None) };
        })?;
        Ok(Self { raster, resolve, budget, columns, rows, words: Vec::new() })
    }

    /// A tile's side in texels.
    pub fn tile(&self) -> u32 {
        self.budget.tile
    }

    /// Tiles across the atlas.
    pub fn columns(&self) -> u32 {
        self.columns
    }

    /// Plans this frame's views for `lights` (by slot) seen from `camera`, and hands them to
    /// the scene (uploaded with its next sync, only when they changed).
    pub fn plan(&mut self, scene: &mut GpuScene, lights: &[GpuLight], camera: &GpuCamera) -> ShadowMapPlan {
        let plan = plan_views(&mut self.words, lights, camera, &self.budget);
        scene.shadow_views.set(&self.words);
        plan
    }

    /// Draws the `plan`'s views into the atlas, then resolves them into the shadow words for
    /// this frame's depth.
    pub fn record(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        plan: ShadowMapPlan,
        inputs: &ShadowInputs,
    ) -> Result<(), RenderError> {
        let size = vk::Extent2D { width: self.columns * self.budget.tile, height: self.rows * self.budget.tile };
        f.graph.fixed_target(f.ctx, &SHADOW_MAP_DEPTH, size)?;
        f.graph.fixed_target(f.ctx, &SHADOW_MAP_FILTER, size)?;
        if plan.views > 0 {
            let (tile, columns, raster) = (self.budget.tile, self.columns, self.raster);
            // Only the rows of tiles in use are cleared and drawn.
            let used = vk::Extent2D { width: size.width, height: plan.views.div_ceil(self.columns) * self.budget.tile };
            f.pass("shadow_maps", PassKind::Graphics)
                .area(used)
                .image(&SHADOW_MAP_DEPTH, ImageUse::DepthWrite(Load::ClearDepth(0.0)))
                .color(&SHADOW_MAP_FILTER, Load::Clear([1.0; 4]))
                .reads(scene.res.drawn())
                .reads(draws.reads())
                .record(|p| {
                    let mut push = p.push;
                    for v in 0..plan.views {
                        push.texture_index = v;
                        p.bind_graphics(raster, &push);
                        let (x, y) = ((v % columns * tile) as f32, (v / columns * tile) as f32);
                        let t = tile as f32;
                        // Flipped like the views' viewports (gpu::pipeline::set_viewport), so
                        // faces keep their winding.
                        let viewport = vk::Viewport { x, y: y + t, width: t, height: -t, min_depth: 0.0, max_depth: 1.0 };
                        let scissor = vk::Rect2D {
                            offset: vk::Offset2D { x: x as i32, y: y as i32 },
                            extent: vk::Extent2D { width: tile, height: tile },
                        };
                        // Viewport and scissor are dynamic and lie in the atlas.
                        p.cmd.set_viewport(viewport, scissor);
                        draws.shadow_view(p, v);
                    }
                })?;
        }
        let extent = f.graph.extent();
        let resolve = self.resolve[usize::from(inputs.glass)];
        f.pass(if inputs.glass { "glass_shadows_maps" } else { "shadows_maps" }, PassKind::Compute)
            .sample(if inputs.glass { &TRANSPARENT_DEPTH } else { &DEPTH })
            .sample(&SHADOW_MAP_DEPTH)
            .sample(&SHADOW_MAP_FILTER)
            .reads(scene.res.shaded())
            .reads(inputs.light_tiles.map(|t| (t, BufferUse::Storage)))
            .write(inputs.shadow_bits, BufferUse::Storage)
            .when(inputs.debug, |p| p.image(&SHADOW_DEBUG, ImageUse::StorageWrite))
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, resolve, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
            })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.raster].into_iter().chain(self.resolve) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}

/// Reverse-Z perspective (near → 1, far → 0) with a square aspect.
fn perspective(fov: f32, far: f32) -> Mat4 {
    Mat4::perspective_rh(fov, 1.0, far, NEAR)
}

/// An up vector not parallel to `dir`.
fn up_for(dir: Vec3) -> Vec3 {
    if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

/// The cube faces' directions, in the order `cube_face` in `shaders/include/shadow_maps.glsl`
/// numbers them.
const CUBE_FACES: [Vec3; 6] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];

/// A directional light's view: orthographic over the bounding sphere of the camera's view up
/// to `distance`, its centre snapped to whole texels in the light's frame, reaching
/// [`CASTER_REACH`] towards the light for casters outside the view.
fn directional_view(dir: Vec3, camera: &GpuCamera, distance: f32, tile: u32) -> GpuShadowView {
    let eye = camera.position;
    let forward = camera.view.inverse().z_axis.xyz().normalize_or(Vec3::NEG_Z) * -1.0;
    let corners = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)].map(|(x, y)| {
        let near = camera.inv_view_proj.project_point3(Vec3::new(x, y, 1.0));
        let ray = (near - eye).normalize_or(forward);
        eye + ray * (distance / ray.dot(forward).max(0.05))
    });
    let centre = (corners.iter().copied().sum::<Vec3>() + eye) / 5.0;
    let radius = corners.iter().chain([&eye]).map(|c| c.distance(centre)).fold(0.0f32, f32::max).max(0.1);
    let texel = 2.0 * radius / tile as f32;
    let rotation = Mat4::look_to_rh(Vec3::ZERO, dir, up_for(dir));
    let local = rotation.transform_point3(centre);
    let snapped = Vec3::new((local.x / texel).floor() * texel, (local.y / texel).floor() * texel, local.z);
    let centre = rotation.inverse().transform_point3(snapped);
    let from = centre - dir * (radius + CASTER_REACH);
    let view = Mat4::look_to_rh(from, dir, up_for(dir));
    let far = 2.0 * radius + CASTER_REACH;
    let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, far, 0.0);
    GpuShadowView { view_proj: proj * view, texel, ortho: 1, pad: [0; 2] }
}

/// Plans the shadow views of `lights` (indexed by slot) into `words` (the layout of
/// `shaders/include/shadow_maps.glsl`): in slot order, each light takes the tiles its kind
/// needs while the budget lasts.
pub fn plan_views(words: &mut Vec<u32>, lights: &[GpuLight], camera: &GpuCamera, budget: &ShadowMapBudget) -> ShadowMapPlan {
    let slots = lights.len();
    let views_at = (SHADOW_VIEWS_HEADER as usize + slots).next_multiple_of(4);
    words.clear();
    words.resize(views_at, 0);
    let mut plan = ShadowMapPlan::default();
    let push = |words: &mut Vec<u32>, view: GpuShadowView| words.extend_from_slice(bytemuck::cast_slice(&[view]));
    for (slot, light) in lights.iter().enumerate() {
        let first = &mut words[SHADOW_VIEWS_HEADER as usize + slot];
        *first = NO_SHADOW_MAP;
        let needs = match light.kind {
            LIGHT_POINT => 6,
            LIGHT_SPOT | LIGHT_DIRECTIONAL => 1,
            _ => continue,
        };
        if plan.views + needs > budget.tiles {
            plan.missing += 1;
            continue;
        }
        *first = plan.views;
        plan.views += needs;
        let far = if light.range.is_finite() && light.range > NEAR { light.range } else { FAR_UNBOUNDED };
        match light.kind {
            LIGHT_POINT => {
                for dir in CUBE_FACES {
                    let view = Mat4::look_to_rh(light.position, dir, up_for(dir));
                    let texel = 2.0 / budget.tile as f32;
                    push(
                        words,
                        GpuShadowView { view_proj: perspective(std::f32::consts::FRAC_PI_2, far) * view, texel, ortho: 0, pad: [0; 2] },
                    );
                }
            }
            LIGHT_SPOT => {
                let fov = (2.0 * light.cone_sin.atan2(light.cone_cos)).clamp(0.02, 2.8);
                let view = Mat4::look_to_rh(light.position, light.direction, up_for(light.direction));
                let texel = 2.0 * (fov / 2.0).tan() / budget.tile as f32;
                push(words, GpuShadowView { view_proj: perspective(fov, far) * view, texel, ortho: 0, pad: [0; 2] });
            }
            _ => push(words, directional_view(light.direction, camera, budget.directional_distance, budget.tile)),
        }
    }
    words[0] = views_at as u32;
    words[1] = plan.views;
    plan
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> GpuCamera {
        let view = Mat4::look_at_rh(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y);
        let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.5, 0.1);
        GpuCamera {
            view,
            proj,
            view_proj: proj * view,
            inv_view_proj: (proj * view).inverse(),
            position: Vec3::new(0.0, 2.0, 5.0),
            ..bytemuck::Zeroable::zeroed()
        }
    }

    fn view_of(words: &[u32], v: u32) -> GpuShadowView {
        let at = words[0] as usize + v as usize * std::mem::size_of::<GpuShadowView>() / 4;
        *bytemuck::from_bytes(bytemuck::cast_slice(&words[at..at + std::mem::size_of::<GpuShadowView>() / 4]))
    }

    #[test]
    fn lights_take_tiles_in_slot_order_until_the_budget_is_spent() {
        let lights = [
            GpuLight::spot(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y, Vec3::ONE, 10.0, 0.2, 0.5),
            bytemuck::Zeroable::zeroed(), // a free slot
            GpuLight::point(Vec3::new(1.0, 2.0, 0.0), Vec3::ONE, 8.0),
            GpuLight::point(Vec3::new(-1.0, 2.0, 0.0), Vec3::ONE, 8.0),
            GpuLight::directional(Vec3::new(0.3, -1.0, 0.2), Vec3::ONE),
        ];
        let budget = ShadowMapBudget { tile: 256, tiles: 8, directional_distance: 20.0 };
        let mut words = Vec::new();
        let plan = plan_views(&mut words, &lights, &camera(), &budget);
        // Spot 1 + point 6 = 7; the second point light does not fit, the directional one does.
        assert_eq!(plan, ShadowMapPlan { views: 8, missing: 1 });
        let first: Vec<u32> = words[4..9].to_vec();
        assert_eq!(first, [0, NO_SHADOW_MAP, 1, NO_SHADOW_MAP, 7]);
        assert_eq!(words[0] % 4, 0);
        assert_eq!(words.len(), words[0] as usize + 8 * std::mem::size_of::<GpuShadowView>() / 4);
        // The spot light's view sees the point under it at its centre, nearer than its range.
        let spot = view_of(&words, 0).view_proj.project_point3(Vec3::new(0.0, 0.0, 0.0));
        assert!(spot.x.abs() < 1e-4 && spot.y.abs() < 1e-4 && spot.z > 0.0 && spot.z < 1.0, "{spot}");
        // Each cube face sees the point in its direction at its centre.
        for (face, dir) in CUBE_FACES.into_iter().enumerate() {
            let p = view_of(&words, 1 + face as u32).view_proj.project_point3(Vec3::new(1.0, 2.0, 0.0) + dir);
            assert!(p.x.abs() < 1e-4 && p.y.abs() < 1e-4 && p.z > 0.0 && p.z < 1.0, "face {face}: {p}");
        }
        // The directional light's view holds what the camera sees up to its distance, and the
        // casters towards the light.
        let sun = view_of(&words, 7);
        assert_eq!(sun.ortho, 1);
        for p in [Vec3::ZERO, Vec3::new(0.0, 2.0, 5.0), Vec3::new(0.0, 0.0, -10.0), Vec3::new(-0.3, 30.0, -0.2)] {
            let q = sun.view_proj.project_point3(p);
            assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && q.z > 0.0 && q.z < 1.0, "{p} → {q}");
        }
    }

    #[test]
    fn the_directional_view_moves_in_whole_texels() {
        let budget = ShadowMapBudget { tile: 512, tiles: 1, directional_distance: 30.0 };
        let lights = [GpuLight::directional(Vec3::new(0.4, -1.0, 0.3), Vec3::ONE)];
        let (mut a, mut b) = (Vec::new(), Vec::new());
        plan_views(&mut a, &lights, &camera(), &budget);
        let mut moved = camera();
        moved.position += Vec3::new(0.013, 0.0, 0.021);
        moved.view = Mat4::look_at_rh(moved.position, Vec3::new(0.013, 0.0, 0.021), Vec3::Y);
        moved.inv_view_proj = (moved.proj * moved.view).inverse();
        plan_views(&mut b, &lights, &moved, &budget);
        let (va, vb) = (view_of(&a, 0), view_of(&b, 0));
        assert!((va.texel - vb.texel).abs() < 1e-6, "the map's size does not change as the camera moves");
        // A fixed world point lands on the same texel grid: its texel coordinates differ by
        // whole texels.
        let texels = |v: &GpuShadowView| v.view_proj.project_point3(Vec3::new(0.7, 0.0, -0.4)).truncate() * 0.5 * budget.tile as f32;
        let shift = texels(&va) - texels(&vb);
        assert!((shift.x - shift.x.round()).abs() < 1e-2 && (shift.y - shift.y.round()).abs() < 1e-2, "{shift}");
    }
}
