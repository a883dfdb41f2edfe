//! Ray-traced reflections on lavapipe (`render::reflections`): a mirror floor shows a lit wall,
//! and the bullet hole on it, at their mirror images, classified per pixel by tracing the same
//! rays on the CPU, in every pipeline, on both ray-tracing tiers, with every decal method; a
//! mirror shows a panel behind the camera lit by a light whose range reaches no pixel the camera
//! sees; glass and alpha-masked geometry in a reflection; and a device without ray tracing says
//! that nothing was reflected.

use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{RenderSettings, RenderStats};
use render::{DecalMethod, DirectLight, PipelineKind, ReflectionMode, ReflectionSettings, Tier};
use tests::{assert_no_validation_errors, gpu_app_at, renderer};

const SIZE: (u32, u32) = (96, 72);
const CLEAR: [f32; 4] = [0.2, 0.3, 0.8, 1.0];
/// The wall's front face (z), its extent in x and y, and the decal's square on it.
const WALL_Z: f32 = -2.9;
const WALL_X: f32 = 1.2;
const WALL_TOP: f32 = 1.6;
const DECAL_CENTRE: Vec2 = Vec2::new(0.3, 0.7);
const DECAL_HALF: f32 = 0.35;

/// What a pixel of the mirror-floor scene should show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Seen {
    /// Not the floor, or too near an edge to say.
    Unknown,
    /// The floor reflecting the sky.
    Sky,
    /// The floor reflecting the wall.
    Wall,
    /// The floor reflecting the decal on the wall.
    Decal,
}

/// Traces the camera ray through `at` (pixels) on the CPU: where it meets the floor (y = 0),
/// mirrored, where that ray meets the wall's front face.
fn seen_at(camera: &Camera, transform: &GlobalTransform, at: Vec2) -> Seen {
    let (origin, dir) = camera.ray(transform, at, Vec2::new(SIZE.0 as f32, SIZE.1 as f32)).unwrap();
    if dir.y >= -1e-4 {
        return Seen::Unknown;
    }
    let t = -origin.y / dir.y;
    let p = origin + dir * t;
    if p.z < WALL_Z + 0.25 || p.x.abs() > 3.5 || p.z > 3.5 {
        return Seen::Unknown; // under the wall, or off the floor
    }
    let r = Vec3::new(dir.x, -dir.y, dir.z);
    if r.z >= -1e-4 {
        return Seen::Sky;
    }
    let q = p + r * ((WALL_Z - p.z) / r.z);
    if q.x.abs() > WALL_X || q.y > WALL_TOP {
        return Seen::Sky;
    }
    let d = (Vec2::new(q.x, q.y) - DECAL_CENTRE).abs();
    if d.x < DECAL_HALF && d.y < DECAL_HALF { Seen::Decal } else { Seen::Wall }
}

/// The class of a pixel, where its centre and four corners agree.
fn expected(camera: &Camera, transform: &GlobalTransform, x: u32, y: u32) -> Seen {
    let centre = seen_at(camera, transform, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
    let agree = corners.iter().all(|&(dx, dy)| seen_at(camera, transform, Vec2::new(x as f32 + dx, y as f32 + dy)) == centre);
    if agree { centre } else { Seen::Unknown }
}

/// What the image shows at a pixel: the wall is lit white, the decal red, the sky blue.
fn classify(c: [f32; 4]) -> Seen {
    let [r, g, b, _] = c;
    if r > 0.1 && r > 2.0 * g && r > 2.0 * b {
        Seen::Decal
    } else if b > 1.5 * r && b > 0.2 {
        Seen::Sky
    } else if r > 0.25 && (r - g).abs() < 0.25 * r && (r - b).abs() < 0.25 * r {
        Seen::Wall
    } else {
        Seen::Unknown
    }
}

fn mirror_floor_app(tier: Tier, pipeline: PipelineKind, method: DecalMethod, reflections: ReflectionSettings) -> (App, Camera, Transform) {
    let settings = RenderSettings { pipeline, decal_method: method, reflections, clear_color: CLEAR, ..Default::default() };
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
    let (mirror, wall) = {
        let mut materials = app.world.resource_mut::<Assets<Material>>();
        (materials.add(Material::from_color(Vec4::ONE, 1.0, 0.0)), materials.add(Material::from_color(Vec4::splat(0.8), 0.0, 0.9)))
    };
    let (floor_mesh, wall_mesh) = {
        let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
        (meshes.add(shapes::cuboid(Vec3::new(8.0, 0.1, 8.0), 1.0)), meshes.add(shapes::cuboid(Vec3::new(2.0 * WALL_X, WALL_TOP, 0.2), 1.0)))
    };
    app.world.spawn((MeshInstance { mesh: floor_mesh, material: mirror }, Transform::from_xyz(0.0, -0.05, 0.0)));
    app.world.spawn((MeshInstance { mesh: wall_mesh, material: wall }, Transform::from_xyz(0.0, WALL_TOP * 0.5, WALL_Z - 0.1)));
    let red = app
        .world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(Vec4::new(1.0, 0.0, 0.0, 1.0)), ..Default::default() });
    let size = Vec3::new(2.0 * DECAL_HALF, 2.0 * DECAL_HALF, 0.4);
    app.world.spawn((Decal::new(red), Transform::from_xyz(DECAL_CENTRE.x, DECAL_CENTRE.y, WALL_Z).with_scale(size)));
    // A sun on the wall's face (and at a grazing angle on the floor, whose highlight leaves the
    // view).
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.2, -0.5, -1.0), Vec3::Y),
    ));
    let camera = Camera::default();
    let transform = Transform::from_xyz(0.0, 1.1, 3.0).looking_at(Vec3::new(0.0, -0.3, -2.0), Vec3::Y);
    app.world.spawn((camera, transform));
    (app, camera, transform)
}

/// The mirror-floor scene on one tier, rendered in turn with each pipeline and decal method a test
/// names (one app: the settings change between renders; reflections keep no history).
struct MirrorFloor {
    tier: Tier,
    app: App,
    camera: Camera,
    transform: Transform,
}

impl MirrorFloor {
    fn new(tier: Tier) -> Self {
        let (app, camera, transform) = mirror_floor_app(tier, PipelineKind::Forward, DecalMethod::Clustered, ReflectionSettings::default());
        Self { tier, app, camera, transform }
    }

    /// Renders the mirror floor with `pipeline` and `method` (reflections at half resolution
    /// when `half`) and counts pixels whose class matches the CPU's, per class.
    fn check(&mut self, pipeline: PipelineKind, method: DecalMethod, half: bool) -> render::reflections::ReflectionStats {
        let Self { tier, app, camera, transform } = self;
        let (tier, camera, transform) = (*tier, *camera, *transform);
        {
            let mut settings = app.world.resource_mut::<RenderSettings>();
            settings.pipeline = pipeline;
            settings.decal_method = method;
            settings.reflections = ReflectionSettings { half_resolution: half, ..Default::default() };
        }
        // Three frames: the statistics come back once a frame slot comes round.
        for _ in 0..3 {
            app.update();
        }
        let hdr = renderer(app).read_hdr().expect("HDR reads back");
        assert_no_validation_errors(app);
        let global = GlobalTransform::from(transform);
        let mut counts = [[0usize; 2]; 3]; // [sky, wall, decal] × [expected, matched]
        for y in 0..SIZE.1 {
            for x in 0..SIZE.0 {
                let want = expected(&camera, &global, x, y);
                let i = match want {
                    Seen::Unknown => continue,
                    Seen::Sky => 0,
                    Seen::Wall => 1,
                    Seen::Decal => 2,
                };
                counts[i][0] += 1;
                // Half resolution blurs mirror images by a pixel: compare with the neighbourhood.
                let got = classify(hdr[(y * SIZE.0 + x) as usize]);
                if got == want {
                    counts[i][1] += 1;
                }
            }
        }
        let label = format!("{tier:?} {pipeline:?} {method:?} half {half}");
        eprintln!("{label}: [expected, matched] sky/wall/decal {counts:?}");
        for (i, name) in ["sky", "wall", "decal"].iter().enumerate() {
            let [n, matched] = counts[i];
            assert!(n >= 12, "{label}: the view sees the {name} in the mirror ({n} pixels)");
            // Half resolution blurs the mirror image by a pixel; screen-space rays at half
            // resolution lose a little more at the wall's foot.
            let share = match (tier == Tier::NoRayTracing, half) {
                (_, false) => 0.9,
                (false, true) => 0.8,
                (true, true) => 0.75,
            };
            assert!(matched as f64 >= share * n as f64, "{label}: the mirror shows the {name} where it should: {matched} of {n} pixels");
        }
        let stats = app.world.resource::<RenderStats>().last.reflections;
        if tier == Tier::NoRayTracing {
            // Screen space: the decal is on screen, so its reflection is found in the lit image.
            assert_eq!(stats.applied, ReflectionMode::ScreenSpace, "{label}");
            assert!(stats.rays > 0 && stats.hits > 0 && stats.decals_tested == 0 && !stats.decals_at_hits, "{label}: {stats:?}");
        } else {
            assert_eq!(stats.applied, ReflectionMode::RayTraced, "{label}");
            assert!(stats.rays > 0 && stats.hits > 0 && stats.decals_tested > 0 && stats.decals_at_hits, "{label}: {stats:?}");
        }
        stats
    }
}

/// Half resolution traces about a ray per 2×2 pixels that reflect.
fn assert_a_ray_per_block(stats: render::reflections::ReflectionStats) {
    assert!(stats.rays * 3 < stats.pixels && stats.rays * 5 > stats.pixels, "a ray per 2×2 block: {stats:?}");
}

#[test]
fn a_mirror_floor_reflects_the_wall_and_its_decal_at_their_mirror_images() {
    // Every pipeline, with in-shader ray-query decals on screen (Forward+ runs forward's frame
    // with tiled lights: it is checked on the ray-tracing-pipeline tier below).
    let mut floor = MirrorFloor::new(Tier::RayQuery);
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        let stats = floor.check(pipeline, DecalMethod::RayQuery, false);
        let pixels = (SIZE.0 * SIZE.1) as u64;
        assert!(stats.rays <= pixels && stats.rays == stats.pixels, "{pipeline:?}: a ray per reflecting pixel: {stats:?}");
    }
    // Whatever the decal method on screen, the hit points find the decals in the decal TLAS.
    for (pipeline, method) in [
        (PipelineKind::Forward, DecalMethod::RayQueryCompute),
        (PipelineKind::Forward, DecalMethod::Clustered),
        (PipelineKind::Deferred, DecalMethod::DeferredDecals),
        (PipelineKind::VisBuffer, DecalMethod::Clustered),
    ] {
        floor.check(pipeline, method, false);
    }
    // Half resolution: about a ray per 2×2 pixels.
    let stats = floor.check(PipelineKind::Deferred, DecalMethod::RayQuery, true);
    assert_a_ray_per_block(stats);
}

#[test]
fn the_ray_tracing_pipeline_tier_reflects_the_wall_and_its_decal_too() {
    let mut floor = MirrorFloor::new(Tier::RayTracingPipeline);
    for (pipeline, method) in [
        (PipelineKind::ForwardPlus, DecalMethod::RayPipeline),
        (PipelineKind::Deferred, DecalMethod::RayPipeline),
        (PipelineKind::VisBuffer, DecalMethod::Clustered),
        (PipelineKind::Deferred, DecalMethod::DeferredDecals),
    ] {
        floor.check(pipeline, method, false);
    }
    let stats = floor.check(PipelineKind::VisBuffer, DecalMethod::RayPipeline, true);
    assert_a_ray_per_block(stats);
}

#[test]
fn without_ray_tracing_reflections_are_marched_in_screen_space() {
    // The wall and its decal are on screen: the mirror shows them.
    let mut floor = MirrorFloor::new(Tier::NoRayTracing);
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        floor.check(pipeline, DecalMethod::Clustered, false);
    }
    floor.check(PipelineKind::Deferred, DecalMethod::DeferredDecals, true);
}

/// Renders the mirror-floor scene of `pipeline` once for each of `materials`: with a slab of that
/// material (if any) high above the floor between the camera and the wall, where only the mirror
/// shows it. One app renders them all, a new slab each time (reflections keep no history).
fn with_slabs(
    tier: Tier,
    pipeline: PipelineKind,
    materials: Vec<Option<Material>>,
) -> Vec<(Vec<[f32; 4]>, render::reflections::ReflectionStats)> {
    let method = if tier == Tier::RayQuery { DecalMethod::RayQuery } else { DecalMethod::RayPipeline };
    let (mut app, ..) = mirror_floor_app(tier, pipeline, method, ReflectionSettings::default());
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(3.0, 1.4, 0.02), 1.0));
    let mut slab: Option<Entity> = None;
    materials
        .into_iter()
        .map(|material| {
            if let Some(old) = slab.take() {
                app.world.despawn(old);
            }
            if let Some(material) = material {
                let material = app.world.resource_mut::<Assets<Material>>().add(material);
                slab = Some(app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(0.0, 3.3, -2.0))).id());
            }
            for _ in 0..3 {
                app.update();
            }
            let hdr = renderer(&mut app).read_hdr().expect("HDR reads back");
            assert_no_validation_errors(&mut app);
            (hdr, app.world.resource::<RenderStats>().last.reflections)
        })
        .collect()
}

#[test]
fn masked_surfaces_are_alpha_tested_and_glass_is_blended_in_reflections() {
    let (camera, transform) =
        (Camera::default(), GlobalTransform::from(Transform::from_xyz(0.0, 1.1, 3.0).looking_at(Vec3::new(0.0, -0.3, -2.0), Vec3::Y)));
    for (tier, pipeline) in [
        (Tier::RayQuery, PipelineKind::Deferred),
        (Tier::RayQuery, PipelineKind::VisBuffer),
        (Tier::RayTracingPipeline, PipelineKind::Deferred),
    ] {
        let green = Vec4::new(0.0, 1.0, 0.0, 0.2);
        // Without the slab; the slab opaque (alpha above its cutoff); alpha under its cutoff
        // everywhere; as glass of opacity 0.5.
        let mut renders = with_slabs(
            tier,
            pipeline,
            vec![
                None,
                Some(Material { alpha_mode: AlphaMode::Mask(0.1), ..Material::from_color(green, 0.0, 0.9) }),
                Some(Material { alpha_mode: AlphaMode::Mask(0.5), ..Material::from_color(green, 0.0, 0.9) }),
                Some(Material { alpha_mode: AlphaMode::Blend, ..Material::from_color(green.with_w(0.5), 0.0, 0.9) }),
            ],
        )
        .into_iter();
        let mut next = || renders.next().expect("one render a material");
        let ((plain, _), (opaque, _), (masked, _), (glass, stats)) = (next(), next(), next(), next());
        // The opaque slab: the pixels it changes are all on the floor.
        let changed: Vec<usize> = (0..plain.len()).filter(|&i| (0..3).any(|c| (opaque[i][c] - plain[i][c]).abs() > 0.05)).collect();
        assert!(changed.len() > 100, "{tier:?} {pipeline:?}: the mirror shows the slab ({} pixels)", changed.len());
        let on_floor = |i: usize| expected(&camera, &transform, i as u32 % SIZE.0, i as u32 / SIZE.0) != Seen::Unknown;
        let off_floor = changed.iter().filter(|&&i| !on_floor(i)).count();
        assert!(
            off_floor * 20 < changed.len(),
            "{tier:?} {pipeline:?}: only the mirror shows it ({off_floor} of {} elsewhere)",
            changed.len()
        );
        // Alpha under its cutoff everywhere: cut away, in reflections too.
        let worst =
            plain.iter().zip(&masked).map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max)).fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{tier:?} {pipeline:?}: a cut-away slab leaves the image as it was (largest difference {worst})");
        // As glass of opacity 0.5 over the sky: green, with half the sky's blue left.
        let mean = |img: &[[f32; 4]]| changed.iter().map(|&i| Vec3::from_slice(&img[i][..3])).sum::<Vec3>() / changed.len() as f32;
        let (sky, tinted) = (mean(&plain), mean(&glass));
        eprintln!("{tier:?} {pipeline:?}: where the slab shows, without it {sky}, glass {tinted}, opaque {}", mean(&opaque));
        assert!(
            tinted.y > sky.y + 0.05 && tinted.z > 0.3 * sky.z && tinted.z < 0.7 * sky.z,
            "{tier:?} {pipeline:?}: glass blended over the sky: {sky} / {tinted}"
        );
        assert!(stats.through_glass > 0, "{tier:?} {pipeline:?}: {stats:?}");
    }
}

#[test]
fn a_mirror_shows_what_a_light_the_camera_does_not_see_lights_and_its_shadow() {
    // Forward+ culls lights by screen tiles, where this one is in none; both tiers find it in the
    // lights' TLAS at the hit point, and trace its shadow ray (the ray-tracing-pipeline tier for
    // the strongest few lights there).
    for (tier, pipeline) in [
        (Tier::RayQuery, PipelineKind::ForwardPlus),
        (Tier::RayQuery, PipelineKind::Deferred),
        (Tier::RayTracingPipeline, PipelineKind::ForwardPlus),
    ] {
        // One app: the panel unlit, then with the light, then with the occluder too.
        let settings = RenderSettings { pipeline, clear_color: [0.0, 0.0, 0.0, 1.0], ambient: Vec3::splat(0.01), ..Default::default() };
        let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
        let (mirror, panel) = {
            let mut materials = app.world.resource_mut::<Assets<Material>>();
            (materials.add(Material::from_color(Vec4::ONE, 1.0, 0.0)), materials.add(Material::from_color(Vec4::splat(0.8), 0.0, 0.9)))
        };
        let (wall, square, small) = {
            let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
            (
                meshes.add(shapes::cuboid(Vec3::new(6.0, 4.0, 0.1), 1.0)),
                meshes.add(shapes::cuboid(Vec3::new(1.5, 1.5, 0.1), 1.0)),
                meshes.add(shapes::cuboid(Vec3::new(0.3, 0.3, 0.02), 1.0)),
            )
        };
        // A mirror ahead; behind the camera a panel, and (from the second render) a light of 1 m
        // range in front of it, which reaches nothing the camera sees directly.
        app.world.spawn((MeshInstance { mesh: wall, material: mirror }, Transform::from_xyz(0.0, 1.0, -3.0)));
        app.world.spawn((MeshInstance { mesh: square, material: panel }, Transform::from_xyz(0.0, 1.0, 3.0)));
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(0.0, 1.0, -3.0), Vec3::Y)));
        let render = |app: &mut App| {
            for _ in 0..2 {
                app.update();
            }
            let hdr = renderer(app).read_hdr().expect("HDR reads back");
            assert_no_validation_errors(app);
            // Four pixels right of the middle: on the panel's image, off the occluder's.
            let at = hdr[(SIZE.1 / 2 * SIZE.0 + SIZE.0 / 2 + 4) as usize];
            Vec3::from_slice(&at[..3])
        };
        let dark = render(&mut app);
        app.world.spawn((PointLight { intensity: 5.0, range: Some(1.0), ..Default::default() }, Transform::from_xyz(0.0, 1.0, 2.4)));
        let lit = render(&mut app);
        // On the ray-query tier the hit point's lights are drawn from as ray-query lights draw
        // (`shaders/include/ray_query_lights.glsl`): with one light the draw is that light, so
        // the panel looks the same lit and shadowed (the drawn path's sum and its one ray give
        // the light and its shadow; this cannot tell whether the hit drew at all).
        let sampled = |app: &mut App| {
            (tier == Tier::RayQuery).then(|| {
                app.world.resource_mut::<RenderSettings>().lights.direct_light = DirectLight::Stochastic;
                let seen = render(app);
                app.world.resource_mut::<RenderSettings>().lights.direct_light = DirectLight::Auto;
                seen
            })
        };
        let lit_sampled = sampled(&mut app);
        // 10 cm in front of the light: its shadow covers the panel; its own image, the middle of
        // the panel's.
        app.world.spawn((MeshInstance { mesh: small, material: panel }, Transform::from_xyz(0.0, 1.0, 2.5)));
        let shadowed = render(&mut app);
        eprintln!("{tier:?} {pipeline:?}: the panel in the mirror unlit {dark}, lit {lit}, in the occluder's shadow {shadowed}");
        if let (Some(lit_sampled), Some(shadowed_sampled)) = (lit_sampled, sampled(&mut app)) {
            assert!(lit_sampled.abs_diff_eq(lit, 1e-3 * lit.x), "{tier:?} {pipeline:?}: sampled, lit {lit_sampled} against {lit}");
            assert!(
                shadowed_sampled.abs_diff_eq(shadowed, 1e-3 * lit.x),
                "{tier:?} {pipeline:?}: sampled, shadowed {shadowed_sampled} against {shadowed}"
            );
        }
        assert!(
            lit.x > 0.1 && lit.x > 10.0 * dark.x,
            "{tier:?} {pipeline:?}: the light behind the camera lights the panel in the mirror: {dark} / {lit}"
        );
        assert!(shadowed.x < 0.1 * lit.x, "{tier:?} {pipeline:?}: the hit point's shadow ray finds the occluder: {lit} / {shadowed}");
        // The light as a 0.5 m sphere, whose rays temporal anti-aliasing averages: the panel
        // sees most of it around the occluder, in the mirror too.
        let light = app.world.query_filtered::<Entity, With<PointLight>>().single(&app.world).expect("one light");
        let sphere = PointLight { radius: 0.5, ..*app.world.get::<PointLight>(light).expect("a point light") };
        app.world.entity_mut(light).insert(sphere);
        app.world.resource_mut::<RenderSettings>().aa = render::AntiAliasing::Taa;
        for _ in 0..6 {
            app.update();
        }
        let soft = render(&mut app);
        eprintln!("{tier:?} {pipeline:?}: the panel in the mirror, the light a 0.5 m sphere: {soft}");
        assert!(
            soft.x > 0.3 * lit.x && soft.x < lit.x,
            "{tier:?} {pipeline:?}: the hit point's shadow rays aim at points of the sphere: {lit} / {soft}"
        );
    }
}

#[test]
fn glass_reflects_what_is_behind_the_camera() {
    // A clear pane ahead and a glowing red panel behind the camera: the pane shows the panel at
    // about its Fresnel reflectance, on both tiers, drawn by the forward transparency pass (a
    // camera ray finds the pane) or interlaced into the deferred G-buffer.
    for (tier, pipeline) in [
        (Tier::RayQuery, PipelineKind::Forward),
        (Tier::RayQuery, PipelineKind::VisBuffer),
        (Tier::RayQuery, PipelineKind::Deferred),
        (Tier::RayTracingPipeline, PipelineKind::Forward),
    ] {
        // One app, rendered without reflections, then with them.
        let settings = RenderSettings {
            pipeline,
            reflections: ReflectionSettings::OFF,
            clear_color: [0.0, 0.0, 0.0, 1.0],
            ambient: Vec3::splat(0.01),
            ..Default::default()
        };
        let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
        let (glass, glow) = {
            let mut materials = app.world.resource_mut::<Assets<Material>>();
            (
                materials.add(Material { alpha_mode: AlphaMode::Blend, ..Material::from_color(Vec4::new(1.0, 1.0, 1.0, 0.3), 0.0, 0.0) }),
                materials
                    .add(Material { emissive: Vec3::new(20.0, 0.0, 0.0), ..Material::from_color(Vec4::new(0.0, 0.0, 0.0, 1.0), 0.0, 0.9) }),
            )
        };
        let (pane, panel) = {
            let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
            (meshes.add(shapes::cuboid(Vec3::new(3.0, 3.0, 0.02), 1.0)), meshes.add(shapes::cuboid(Vec3::new(3.0, 3.0, 0.1), 1.0)))
        };
        app.world.spawn((MeshInstance { mesh: pane, material: glass }, Transform::from_xyz(0.0, 1.0, -2.0)));
        app.world.spawn((MeshInstance { mesh: panel, material: glow }, Transform::from_xyz(0.0, 1.0, 3.0)));
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(0.0, 1.0, -3.0), Vec3::Y)));
        let mut render = |reflections: ReflectionSettings| {
            app.world.resource_mut::<RenderSettings>().reflections = reflections;
            for _ in 0..3 {
                app.update();
            }
            let hdr = renderer(&mut app).read_hdr().expect("HDR reads back");
            assert_no_validation_errors(&mut app);
            let stats = app.world.resource::<RenderStats>().last.reflections;
            (Vec3::from_slice(&hdr[(SIZE.1 / 2 * SIZE.0 + SIZE.0 / 2) as usize][..3]), stats)
        };
        let (off, _) = render(ReflectionSettings::OFF);
        let (on, stats) = render(ReflectionSettings::default());
        eprintln!("{tier:?} {pipeline:?}: the pane without reflections {off}, with {on}; {stats:?}");
        assert!(on.x > off.x + 0.2 && on.y < 0.05, "{tier:?} {pipeline:?}: the pane reflects the red panel: {off} / {on}");
        assert!(stats.rays > 0 && stats.hits > 0, "{tier:?} {pipeline:?}: {stats:?}");
    }
}

#[test]
fn reflections_run_only_when_some_material_or_decal_is_smooth_enough() {
    let settings = RenderSettings { pipeline: PipelineKind::Forward, ..Default::default() };
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, Tier::RayQuery);
    let rough = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::splat(0.8), 0.0, 0.9));
    let floor = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(8.0, 0.1, 8.0), 1.0));
    app.world.spawn((MeshInstance { mesh: floor, material: rough }, Transform::from_xyz(0.0, -0.05, 0.0)));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.1, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app.update();
    let stats = app.world.resource::<RenderStats>().last.reflections;
    assert_eq!(stats.applied, ReflectionMode::Off, "nothing smoother than the cut-off: no reflection pass ({stats:?})");
    // A puddle: a decal that makes the floor smooth where it lands.
    let wet = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial {
        base_color: None,
        roughness: Some(0.05),
        ..Default::default()
    });
    app.world
        .spawn((Decal::new(wet), Transform::from_xyz(0.0, 0.0, 0.0).with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))));
    app.update();
    assert_no_validation_errors(&mut app);
    let stats = app.world.resource::<RenderStats>().last.reflections;
    assert_eq!(stats.applied, ReflectionMode::RayTraced, "a smooth decal brings them back ({stats:?})");
    assert!((stats.smoothest - 0.05).abs() < 1e-6, "{stats:?}");
}
