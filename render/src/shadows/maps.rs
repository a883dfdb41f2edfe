//! Shadow maps for devices without ray tracing (issue 12 item 5), with seed 002's coloured
//! shadows (`../shared/seeds/002`, §3.2.1, eqs. 3.1–3.2, Table 3.3), feeding the same
//! visibility input as the ray-traced shadow pass: the shadow bits and tints that every
//! pipeline's shading reads.
//!
//! - **Views** ([`plan_views`], on the CPU, uploaded only when they change): a spot light gets
//!   one perspective view over its cone, a point light six cube faces (and so does an area
//!   light, from its centre: its hard shadow is the centre's, as with rays without temporal
//!   anti-aliasing; a face that sees only what lies behind a one-sided light, when there is
//!   one, is drawn though nothing reads it; a surface within the near plane's 5 cm of the
//!   centre, such as a wall beside a panel mounted in a corner, is missing from the face that
//!   looks at it), a directional light one
//!   orthographic view fitted to the camera's view up to
//!   [`ShadowMapBudget::directional_distance`] (a bounding sphere of that slice of the view
//!   frustum, so the map's size does not change as the camera turns, and its position snapped
//!   to whole texels, so its edges do not crawl as the camera moves). Lights take views in the
//!   order of the light they bring to what the camera sees ([`map_priority`]: directional
//!   lights first, then intensity times the share of the view the light's range can reach)
//!   until the atlas is full; the rest are unshadowed and counted. Issue 52 item 4 asks for
//!   the maps to go to the lights that contribute most; until then they went in slot order, so
//!   the first lights spawned took them, however dim or far.
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
use crate::layout::{
    GpuCamera, GpuLight, GpuShadowView, LIGHT_DIRECTIONAL, LIGHT_DISK, LIGHT_POINT, LIGHT_RECT, LIGHT_SPOT, NO_SHADOW_MAP,
    SHADOW_VIEWS_HEADER,
};
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
    /// The lights ranked by [`map_priority`], rebuilt each frame into the same vector.
    ranked: Vec<(f32, u32)>,
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
        Ok(Self { raster, resolve, budget, columns, rows, words: Vec::new(), ranked: Vec::new() })
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
        let plan = plan_views(&mut self.words, &mut self.ranked, lights, camera, &self.budget);
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

/// Moves the `k` highest-ranked of `ranked` to its front, in rank order (highest
/// [`map_priority`] first, ties by slot), without sorting the rest.
fn best_first(ranked: &mut [(f32, u32)], k: usize) {
    let order = |a: &(f32, u32), b: &(f32, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    if k == 0 {
        return;
    }
    if k < ranked.len() {
        ranked.select_nth_unstable_by(k - 1, order);
    }
    ranked[..k].sort_unstable_by(order);
}

/// Moves the entries that satisfy `keep` to the front of `items` (in no particular order);
/// returns how many there are.
fn partition<T>(items: &mut [T], keep: impl Fn(&T) -> bool) -> usize {
    let mut front = 0;
    for i in 0..items.len() {
        if keep(&items[i]) {
            items.swap(front, i);
            front += 1;
        }
    }
    front
}

/// How much light `light` brings to what a camera at `eye` sees, to rank the lights for the
/// atlas: directional lights first (they reach everything); a point or spot light by its
/// intensity (the luminance of the record's colour; an area light's luminance times its area)
/// times the share of the view its range can reach, the size of its range sphere from the eye
/// (all of it when the eye is inside).
pub fn map_priority(light: &GpuLight, eye: Vec3) -> f32 {
    if light.kind == LIGHT_DIRECTIONAL {
        return f32::INFINITY;
    }
    let luminance = light.color.dot(Vec3::new(0.2126, 0.7152, 0.0722)).max(0.0);
    let intensity = match light.kind {
        LIGHT_RECT | LIGHT_DISK => luminance * light.area(),
        _ => luminance,
    };
    let distance = light.position.distance(eye).max(1e-3);
    let reach = if light.range.is_finite() { (light.range / distance).min(1.0) } else { 1.0 };
    intensity * reach * reach
}

/// Plans the shadow views of `lights` (indexed by slot) into `words` (the layout of
/// `shaders/include/shadow_maps.glsl`): the lights in order of [`map_priority`] (ties in slot
/// order), each taking the tiles its kind needs if they still fit. Only the `budget.tiles`
/// highest-ranked lights are considered (each takes a tile at least), found without sorting
/// them all; `ranked` is reused between frames.
pub fn plan_views(
    words: &mut Vec<u32>,
    ranked: &mut Vec<(f32, u32)>,
    lights: &[GpuLight],
    camera: &GpuCamera,
    budget: &ShadowMapBudget,
) -> ShadowMapPlan {
    let slots = lights.len();
    let views_at = (SHADOW_VIEWS_HEADER as usize + slots).next_multiple_of(4);
    words.clear();
    words.resize(views_at, 0);
    words[SHADOW_VIEWS_HEADER as usize..SHADOW_VIEWS_HEADER as usize + slots].fill(NO_SHADOW_MAP);
    let mut plan = ShadowMapPlan::default();
    let push = |words: &mut Vec<u32>, view: GpuShadowView| words.extend_from_slice(bytemuck::cast_slice(&[view]));
    ranked.clear();
    ranked.extend(
        lights
            .iter()
            .enumerate()
            .filter(|(_, l)| matches!(l.kind, LIGHT_POINT | LIGHT_SPOT | LIGHT_DIRECTIONAL | LIGHT_RECT | LIGHT_DISK))
            .map(|(slot, l)| (map_priority(l, camera.position), slot as u32)),
    );
    let shadowable = ranked.len();
    // The `tiles` best first (each light takes a tile at least, so no other can be needed while
    // they all fit). A cube that no longer fits leaves fewer than six tiles: then only spot and
    // directional lights can take them, the best of those that are left.
    let first = (budget.tiles as usize).min(shadowable);
    best_first(ranked, first);
    let take = |slot: u32, views: &mut u32, words: &mut Vec<u32>| {
        let needs = if is_cube(lights[slot as usize].kind) { 6 } else { 1 };
        let fits = *views + needs <= budget.tiles;
        if fits {
            words[SHADOW_VIEWS_HEADER as usize + slot as usize] = *views;
            *views += needs;
        }
        fits
    };
    let mut chosen = 0;
    for &(_, slot) in &ranked[..first] {
        chosen += usize::from(take(slot, &mut plan.views, words));
    }
    let mut more = 0;
    if plan.views < budget.tiles && first < shadowable {
        let rest = &mut ranked[first..];
        let singles = partition(rest, |&(_, slot)| !is_cube(lights[slot as usize].kind));
        more = ((budget.tiles - plan.views) as usize).min(singles);
        best_first(&mut rest[..singles], more);
        for &(_, slot) in &rest[..more] {
            take(slot, &mut plan.views, words);
        }
        chosen += more;
    }
    plan.missing = (shadowable - chosen) as u32;
    // The views, in the order their tiles were handed out.
    for &(_, slot) in ranked[..first + more].iter() {
        if words[SHADOW_VIEWS_HEADER as usize + slot as usize] == NO_SHADOW_MAP {
            continue;
        }
        let light = &lights[slot as usize];
        let far = if light.range.is_finite() && light.range > NEAR { light.range } else { FAR_UNBOUNDED };
        match light.kind {
            kind if is_cube(kind) => {
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

/// Whether a light of `kind` takes a cube of six views (`shadow_maps.glsl`'s `cube_mapped`):
/// point lights, and area lights from their centre.
fn is_cube(kind: u32) -> bool {
    matches!(kind, LIGHT_POINT | LIGHT_RECT | LIGHT_DISK)
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
    fn lights_take_tiles_in_order_of_their_light_until_the_budget_is_spent() {
        let lights = [
            GpuLight::spot(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y, Vec3::ONE, 10.0, 0.2, 0.5),
            bytemuck::Zeroable::zeroed(), // a free slot
            GpuLight::point(Vec3::new(1.0, 2.0, 0.0), Vec3::ONE, 8.0),
            GpuLight::point(Vec3::new(-1.0, 2.0, 0.0), Vec3::ONE, 8.0),
            GpuLight::directional(Vec3::new(0.3, -1.0, 0.2), Vec3::ONE),
        ];
        let budget = ShadowMapBudget { tile: 256, tiles: 8, directional_distance: 20.0 };
        let (mut words, mut ranked) = (Vec::new(), Vec::new());
        let plan = plan_views(&mut words, &mut ranked, &lights, &camera(), &budget);
        // The directional light first; the others reach the whole view with the same intensity,
        // so they go in slot order: spot 1 + point 6 = 7 after it, and the second point light
        // does not fit.
        assert_eq!(plan, ShadowMapPlan { views: 8, missing: 1 });
        let first: Vec<u32> = words[4..9].to_vec();
        assert_eq!(first, [1, NO_SHADOW_MAP, 2, NO_SHADOW_MAP, 0]);
        assert_eq!(words[0] % 4, 0);
        assert_eq!(words.len(), words[0] as usize + 8 * std::mem::size_of::<GpuShadowView>() / 4);
        // The spot light's view sees the point under it at its centre, nearer than its range.
        let spot = view_of(&words, 1).view_proj.project_point3(Vec3::new(0.0, 0.0, 0.0));
        assert!(spot.x.abs() < 1e-4 && spot.y.abs() < 1e-4 && spot.z > 0.0 && spot.z < 1.0, "{spot}");
        // Each cube face sees the point in its direction at its centre.
        for (face, dir) in CUBE_FACES.into_iter().enumerate() {
            let p = view_of(&words, 2 + face as u32).view_proj.project_point3(Vec3::new(1.0, 2.0, 0.0) + dir);
            assert!(p.x.abs() < 1e-4 && p.y.abs() < 1e-4 && p.z > 0.0 && p.z < 1.0, "face {face}: {p}");
        }
        // The directional light's view holds what the camera sees up to its distance, and the
        // casters towards the light.
        let sun = view_of(&words, 0);
        assert_eq!(sun.ortho, 1);
        for p in [Vec3::ZERO, Vec3::new(0.0, 2.0, 5.0), Vec3::new(0.0, 0.0, -10.0), Vec3::new(-0.3, 30.0, -0.2)] {
            let q = sun.view_proj.project_point3(p);
            assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && q.z > 0.0 && q.z < 1.0, "{p} → {q}");
        }
    }

    #[test]
    fn the_atlas_goes_to_the_lights_that_bring_the_view_most_light() {
        let eye = camera().position;
        let (mut words, mut ranked) = (Vec::new(), Vec::new());
        // One point light's cube fits; the dim one was spawned first.
        let budget = ShadowMapBudget { tile: 256, tiles: 6, directional_distance: 20.0 };
        let dim = GpuLight::point(Vec3::new(0.0, 2.0, 0.0), Vec3::splat(0.5), 8.0);
        let bright = GpuLight::point(Vec3::new(1.0, 2.0, 0.0), Vec3::splat(20.0), 8.0);
        let plan = plan_views(&mut words, &mut ranked, &[dim, bright], &camera(), &budget);
        assert_eq!(plan, ShadowMapPlan { views: 6, missing: 1 });
        assert_eq!(words[4..6], [NO_SHADOW_MAP, 0], "the bright light takes the cube");
        // As bright, but far from the eye with a short range: it reaches a sliver of the view.
        let far = GpuLight::point(eye + Vec3::new(0.0, 0.0, -40.0), Vec3::splat(20.0), 2.0);
        let near = GpuLight::point(eye + Vec3::new(0.0, 0.0, -3.0), Vec3::splat(20.0), 2.0);
        assert!(map_priority(&near, eye) > 100.0 * map_priority(&far, eye));
        plan_views(&mut words, &mut ranked, &[far, near], &camera(), &budget);
        assert_eq!(words[4..6], [NO_SHADOW_MAP, 0], "the light whose range the view is in takes the cube");
        // Fewer tiles than lights: only the best `tiles` are ranked, and a spot light that fits
        // after a cube that does not still gets its tile.
        let budget = ShadowMapBudget { tiles: 2, ..budget };
        let spot = GpuLight::spot(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y, Vec3::splat(5.0), 10.0, 0.2, 0.5);
        let lights = [dim, spot, bright, GpuLight::directional(Vec3::NEG_Y, Vec3::ONE)];
        let plan = plan_views(&mut words, &mut ranked, &lights, &camera(), &budget);
        assert_eq!(plan, ShadowMapPlan { views: 2, missing: 2 });
        assert_eq!(words[4..8], [NO_SHADOW_MAP, 1, NO_SHADOW_MAP, 0]);
        assert!(ranked.capacity() >= 4, "the ranking keeps its room for the next frame");
    }

    #[test]
    fn area_lights_take_a_cube_from_their_centre_ranked_by_their_power() {
        let eye = camera().position;
        let (mut words, mut ranked) = (Vec::new(), Vec::new());
        let budget = ShadowMapBudget { tile: 256, tiles: 6, directional_distance: 20.0 };
        // A 2 m × 1 m panel of luminance 1 brings as much as a point light of intensity 2 (its
        // face's area), more than a point light of 1.5.
        let at = Vec3::new(0.5, 2.5, 0.0);
        let rect = GpuLight::rect(at, Vec3::NEG_Y, Vec3::X, 0.5, Vec3::ONE, 8.0);
        assert!((rect.area() - 2.0).abs() < 1e-5, "{}", rect.area());
        let point = GpuLight::point(Vec3::new(0.5, 2.5, 0.1), Vec3::splat(1.5), 8.0);
        assert!(map_priority(&rect, eye) > map_priority(&point, eye));
        let plan = plan_views(&mut words, &mut ranked, &[point, rect], &camera(), &budget);
        assert_eq!(plan, ShadowMapPlan { views: 6, missing: 1 });
        assert_eq!(words[4..6], [NO_SHADOW_MAP, 0], "the panel takes the cube");
        for (face, dir) in CUBE_FACES.into_iter().enumerate() {
            let p = view_of(&words, face as u32).view_proj.project_point3(at + dir);
            assert!(p.x.abs() < 1e-4 && p.y.abs() < 1e-4 && p.z > 0.0 && p.z < 1.0, "face {face}: {p}");
        }
        let disk = GpuLight::disk(at, Vec3::NEG_Y, Vec3::X, 1.0, Vec3::ONE, 8.0);
        assert!((disk.area() - std::f32::consts::PI).abs() < 1e-5);
        let plan = plan_views(&mut words, &mut ranked, &[disk], &camera(), &budget);
        assert_eq!(plan, ShadowMapPlan { views: 6, missing: 0 });
    }

    #[test]
    fn the_directional_view_moves_in_whole_texels() {
        let budget = ShadowMapBudget { tile: 512, tiles: 1, directional_distance: 30.0 };
        let lights = [GpuLight::directional(Vec3::new(0.4, -1.0, 0.3), Vec3::ONE)];
        let (mut a, mut b, mut ranked) = (Vec::new(), Vec::new(), Vec::new());
        plan_views(&mut a, &mut ranked, &lights, &camera(), &budget);
        let mut moved = camera();
        moved.position += Vec3::new(0.013, 0.0, 0.021);
        moved.view = Mat4::look_at_rh(moved.position, Vec3::new(0.013, 0.0, 0.021), Vec3::Y);
        moved.inv_view_proj = (moved.proj * moved.view).inverse();
        plan_views(&mut b, &mut ranked, &lights, &moved, &budget);
        let (va, vb) = (view_of(&a, 0), view_of(&b, 0));
        assert!((va.texel - vb.texel).abs() < 1e-6, "the map's size does not change as the camera moves");
        // A fixed world point lands on the same texel grid: its texel coordinates differ by
        // whole texels.
        let texels = |v: &GpuShadowView| v.view_proj.project_point3(Vec3::new(0.7, 0.0, -0.4)).truncate() * 0.5 * budget.tile as f32;
        let shift = texels(&va) - texels(&vb);
        assert!((shift.x - shift.x.round()).abs() < 1e-2 && (shift.y - shift.y.round()).abs() < 1e-2, "{shift}");
    }
}
