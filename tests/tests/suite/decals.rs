//! Ray-traced decals on lavapipe: the blending equations against a CPU reference, containment at
//! the box's faces and corners, receiver masks, angle and lifetime fades, normal maps, and ECS
//! sequences whose images *and* work counters are both checked. The blending test runs in each of
//! [`CONFIGS`]: in-shader ray queries (the ray-query tier, forward); the ray-tracing-pipeline
//! decal pass with the tier forced down to `ray_tracing_pipeline` (no ray queries at all); and
//! clustered decals with the tier forced down to `none` (no acceleration structures at all);
//! each in the forward, deferred and visibility-buffer pipelines. So every method and pipeline
//! is held to the same CPU reference there, and the other tests, which check properties of the
//! shared decal maths (`shaders/include/decals.glsl`), run in [`COVER`]: each method once and each
//! way of reading the surface (none, depth, G-buffer, visibility) once.
//!
//! Scenes are a horizontal plane seen from straight above ([`TopDownView`]); the shading pass's
//! debug views write the post-decal albedo and roughness/metallic into the HDR target, which is
//! read back and compared per pixel. Pixels within one pixel footprint of any box edge are
//! skipped: there the GPU's interpolated position and our exact one may fall on different sides.

use engine::prelude::*;
use plugins::decal::{AngleFade, Decal, DecalLifetime, DecalMaterial, DecalReceiver, DistanceFade};
use plugins::{MirrorSlots, RenderMirror, RenderSettings, RenderStats};
use render::graph::targets::Surface;
use render::{DebugView, DecalMethod, PipelineKind, Tier};
use tests::{TopDownView, assert_no_validation_errors, gpu_app_at, renderer};

/// A device tier, pipeline and decal method every decal test runs with.
#[derive(Clone, Copy, Debug)]
struct Config {
    tier: Tier,
    pipeline: PipelineKind,
    method: DecalMethod,
}

const CONFIGS: [Config; 7] = [
    Config { tier: Tier::RayQuery, pipeline: PipelineKind::Forward, method: DecalMethod::RayQuery },
    Config { tier: Tier::RayTracingPipeline, pipeline: PipelineKind::Forward, method: DecalMethod::RayPipeline },
    Config { tier: Tier::RayTracingPipeline, pipeline: PipelineKind::Deferred, method: DecalMethod::RayPipeline },
    Config { tier: Tier::RayTracingPipeline, pipeline: PipelineKind::VisBuffer, method: DecalMethod::RayPipeline },
    Config { tier: Tier::NoRayTracing, pipeline: PipelineKind::Forward, method: DecalMethod::Clustered },
    Config { tier: Tier::NoRayTracing, pipeline: PipelineKind::Deferred, method: DecalMethod::Clustered },
    Config { tier: Tier::NoRayTracing, pipeline: PipelineKind::VisBuffer, method: DecalMethod::Clustered },
];

/// One configuration per decal method and per surface source: ray queries in the shading
/// (forward), the ray-tracing-pipeline pass over the visibility buffer, clustered decals over
/// forward's depth and over deferred's G-buffer. (The full product, [`CONFIGS`], is checked
/// against the CPU blending reference by `random_overlapping_stacks_match_the_cpu_blending_reference`.)
const COVER: [Config; 4] = [CONFIGS[0], CONFIGS[3], CONFIGS[4], CONFIGS[5]];

/// An offscreen app of `size` rendering with `c`, its decal method checked to be the one applied.
fn config_app(c: Config, size: (u32, u32), debug_view: DebugView) -> App {
    let settings = RenderSettings { debug_view, pipeline: c.pipeline, decal_method: c.method, ..Default::default() };
    let mut app = gpu_app_at(size.0, size.1, settings, c.tier);
    assert_eq!(renderer(&mut app).tier(), c.tier, "lavapipe offers every tier");
    app
}

/// Where `c`'s decal pass should read each pixel's surface: nowhere for in-shader ray queries
/// (no pass), the G-buffer in deferred, the prepass's ids in the visibility buffer, and in
/// forward the ids only where a decal needs the instance (`needs_ids`: a receiver with other
/// layers), depth alone otherwise.
fn expected_surface(c: Config, needs_ids: bool) -> Option<Surface> {
    c.method.uses_decal_buffer().then_some(match c.pipeline {
        PipelineKind::Deferred => Surface::GBuffer,
        PipelineKind::VisBuffer => Surface::Visibility,
        _ if needs_ids => Surface::Visibility,
        _ => Surface::Depth,
    })
}

/// Where the last frame recorded had its decal pass read the surface.
fn reported_surface(app: &App) -> Option<Surface> {
    app.world.resource::<RenderStats>().latest().expect("a frame was recorded").decal_surface
}

/// The plane's albedo: sRGB 188/255, which the deferred pipeline's 8-bit sRGB G-buffer holds
/// exactly, so every pipeline sees the same surface (as 0.8 = 204/255 is exact in its 8-bit
/// roughness).
const SURFACE_ALBEDO: Vec3 = Vec3::splat(0.502_886_4);
const SURFACE_ROUGHNESS: f32 = 0.8;
const SURFACE_METALLIC: f32 = 0.0;

/// A decal as the CPU reference sees it.
#[derive(Clone, Debug)]
struct RefDecal {
    to_world: Mat4,
    channel: usize,
    weight: f32,
    albedo: Option<Vec3>,
    alpha: f32,
    roughness: Option<f32>,
    metallic: Option<f32>,
}

/// Seed 000 §4.3.1 per channel, then channels alpha-blended in order (shaders/include/blend.glsl).
fn reference(p: Vec3, decals: &[RefDecal]) -> (Vec3, f32, f32) {
    #[derive(Default, Clone, Copy)]
    struct Acc {
        sum: Vec3,
        vis: f32,
        wsum: f32,
    }
    let fresh = Acc { vis: 1.0, ..Default::default() };
    let mut albedo = [fresh; 4];
    let mut rough = [fresh; 4];
    let mut metal = [fresh; 4];
    for d in decals {
        let local = d.to_world.inverse().transform_point3(p);
        if local.abs().max_element() > 0.5 {
            continue;
        }
        let (a, w, c) = (d.alpha, d.weight, d.channel);
        let add = |acc: &mut Acc, v: Vec3| {
            acc.sum += v * a * w;
            acc.vis *= 1.0 - a;
            acc.wsum += a * w;
        };
        if let Some(v) = d.albedo {
            add(&mut albedo[c], v);
        }
        if let Some(v) = d.roughness {
            add(&mut rough[c], Vec3::splat(v));
        }
        if let Some(v) = d.metallic {
            add(&mut metal[c], Vec3::splat(v));
        }
    }
    let resolve = |accs: &[Acc; 4], mut bg: Vec3| {
        for acc in accs {
            if acc.wsum > 0.0 {
                bg = acc.sum / acc.wsum * (1.0 - acc.vis) + bg * acc.vis;
            }
        }
        bg
    };
    (resolve(&albedo, SURFACE_ALBEDO), resolve(&rough, Vec3::splat(SURFACE_ROUGHNESS)).x, resolve(&metal, Vec3::splat(SURFACE_METALLIC)).x)
}

/// Distance from `p` to the nearest face of any box, in world units (for skipping edge pixels).
fn distance_to_any_face(p: Vec3, decals: &[RefDecal]) -> f32 {
    decals
        .iter()
        .map(|d| {
            let local = d.to_world.inverse().transform_point3(p);
            let scale = Vec3::new(d.to_world.x_axis.length(), d.to_world.y_axis.length(), d.to_world.z_axis.length());
            ((Vec3::splat(0.5) - local.abs()) * scale).abs().min_element()
        })
        .fold(f32::INFINITY, f32::min)
}

/// Projects straight down onto y = 0, rotated by `yaw` about the vertical.
fn downward(centre: Vec3, size: Vec2, depth: f32, yaw: f32) -> Transform {
    Transform::from_translation(centre)
        .with_rotation(Quat::from_rotation_y(yaw) * Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(size.x, size.y, depth))
}

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
}

const SIZE: (u32, u32) = (128, 96);

fn plane_app(c: Config) -> (App, TopDownView) {
    let mut app = config_app(c, SIZE, DebugView::Albedo);
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(
        SURFACE_ALBEDO.extend(1.0),
        SURFACE_METALLIC,
        SURFACE_ROUGHNESS,
    ));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    let view = TopDownView::new(4.0, SIZE);
    view.spawn(&mut app.world);
    (app, view)
}

fn spawn_ref_decal(app: &mut App, d: &RefDecal) -> Entity {
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial {
        base_color: d.albedo.map(|c| c.extend(1.0)),
        roughness: d.roughness,
        metallic: d.metallic,
        ..Default::default()
    });
    let (scale, rotation, translation) = d.to_world.to_scale_rotation_translation();
    let mut decal = Decal::new(material);
    decal.channel = d.channel as u8;
    decal.weight = d.weight;
    decal.opacity = d.alpha;
    app.world.spawn((decal, Transform { translation, rotation, scale })).id()
}

/// Reads the albedo and roughness/metallic views of the current scene.
fn read_views(app: &mut App) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    app.world.resource_mut::<RenderSettings>().debug_view = DebugView::Albedo;
    app.update();
    let albedo = renderer(app).read_hdr().unwrap();
    app.world.resource_mut::<RenderSettings>().debug_view = DebugView::RoughnessMetallic;
    app.update();
    let rm = renderer(app).read_hdr().unwrap();
    (albedo, rm)
}

/// The ray-tracing-pipeline decal pass's list statistics after each of two more frames.
fn list_stats_of_two_more_frames(app: &mut App) -> (render::stats::DecalListStats, render::stats::DecalListStats) {
    app.update();
    let first = counters(app).decal_lists;
    app.update();
    (first, counters(app).decal_lists)
}

#[test]
fn random_overlapping_stacks_match_the_cpu_blending_reference() {
    for c in CONFIGS {
        eprintln!("{c:?}");
        // Seed 4 stacks 40 decals, more than the reflection rays collect in their payload (32:
        // shaders/include/decal_pass.glsl). The ray-tracing-pipeline pass lists the decals in
        // memory, in the room each pixel reserved from the frame before: the first view (the first
        // frame) has none, so its pixels blend in the second trace's any-hit shader; the second
        // view blends the lists after the trace (checked below).
        // Two seeds of 12 decals each (a third checked nothing the two did not), and for the
        // ray-tracing-pipeline pass one of 40 to overflow its lists, first, while the renderer is
        // new. One renderer per configuration: each stack replaces the one before.
        let stacks: &[(u64, usize)] = if c.method == DecalMethod::RayPipeline { &[(4, 40), (1, 12), (2, 12)] } else { &[(1, 12), (2, 12)] };
        let (mut app, view) = plane_app(c);
        let mut spawned: Vec<Entity> = Vec::new();
        for (stack, &(seed, count)) in stacks.iter().enumerate() {
            for e in spawned.drain(..) {
                app.world.despawn(e);
            }
            let mut rng = Lcg(seed);
            let decals: Vec<RefDecal> = (0..count)
                .map(|_| {
                    let t = downward(
                        Vec3::new(rng.range(-1.0, 1.0), 0.0, rng.range(-0.8, 0.8)),
                        Vec2::new(rng.range(1.5, 3.0), rng.range(1.5, 3.0)),
                        1.0,
                        rng.range(0.0, std::f32::consts::TAU),
                    );
                    let has_albedo = rng.next() < 0.8;
                    RefDecal {
                        to_world: t.compute_matrix(),
                        channel: (rng.next() * 4.0) as usize % 4,
                        weight: rng.range(0.3, 3.0),
                        albedo: has_albedo.then(|| Vec3::new(rng.next(), rng.next(), rng.next())),
                        alpha: rng.range(0.2, 1.0),
                        roughness: (rng.next() < 0.5).then(|| rng.next()),
                        metallic: (rng.next() < 0.4).then(|| rng.next()),
                    }
                })
                .collect();
            spawned.extend(decals.iter().map(|d| spawn_ref_decal(&mut app, d)));
            let first = read_views(&mut app);
            assert_no_validation_errors(&mut app);
            let mut views = vec![first];
            if c.method == DecalMethod::RayPipeline && stack == 0 {
                // Frame 1 has no room anywhere: its pixels blend in the second trace's any-hit
                // shader. Frame 2 blends the lists; where the rooms asked for exceed the initial
                // capacity, the pixels past it are denied a list and blend in any-hit at once.
                // Frame 2's need comes back in frame 4, which grows the buffer (keeping what each
                // pixel found), so frames 5 and 6 blend every pixel's list. The statistics of a
                // frame come back two frames later.
                let (one, two) = list_stats_of_two_more_frames(&mut app);
                assert_eq!((one.measured_frame, two.measured_frame), (1, 2), "{one:?} {two:?}");
                assert!(one.overflowed > 0, "the first frame's pixels had no room: {one:?}");
                assert!(two.needed > 0 && two.overflowed == 0, "the second blended its lists: {two:?}");
                views.push(read_views(&mut app));
                let (five, six) = list_stats_of_two_more_frames(&mut app);
                assert_eq!((five.measured_frame, six.measured_frame), (5, 6), "{five:?} {six:?}");
                for f in [five, six] {
                    assert!(f.needed > 0 && f.denied == 0 && f.overflowed == 0, "every pixel blended its list: {f:?}");
                }
                assert_no_validation_errors(&mut app);
                eprintln!("seed {seed}: lists {two:?}, then {six:?}");
            } else if c.method == DecalMethod::RayPipeline {
                // A later stack's first view used the rooms the stack before asked for; once its
                // own need is back (two frames later) every pixel blends its list.
                let (_, last) = list_stats_of_two_more_frames(&mut app);
                views.push(read_views(&mut app));
                let (_, now) = list_stats_of_two_more_frames(&mut app);
                assert!(now.needed > 0 && now.denied == 0 && now.overflowed == 0, "every pixel blended its list: {last:?}, then {now:?}");
                assert_no_validation_errors(&mut app);
            }
            for (albedo, rm) in &views {
                let pixel_world = 2.0 * view.transform.translation.y * (view.camera.fov_y * 0.5).tan() / SIZE.1 as f32;
                let (mut checked, mut covered, mut worst, mut deepest) = (0, 0, 0.0f32, 0);
                for py in 0..SIZE.1 {
                    for px in 0..SIZE.0 {
                        let Some(p) = view.ground_point(px, py, 0.0) else { continue };
                        if distance_to_any_face(p, &decals) < pixel_world {
                            continue;
                        }
                        let depth =
                            decals.iter().filter(|d| d.to_world.inverse().transform_point3(p).abs().cmple(Vec3::splat(0.5)).all()).count();
                        deepest = deepest.max(depth);
                        let (ea, er, em) = reference(p, &decals);
                        let i = (py * SIZE.0 + px) as usize;
                        let got_a = Vec3::from_slice(&albedo[i][..3]);
                        let (got_r, got_m) = (rm[i][0], rm[i][1]);
                        let err = (got_a - ea).abs().max_element().max((got_r - er).abs()).max((got_m - em).abs());
                        worst = worst.max(err);
                        assert!(
                            err <= 1.5e-3,
                            "seed {seed} pixel ({px},{py}) at {p}: gpu albedo {got_a} r {got_r} m {got_m}, cpu {ea} {er} {em}"
                        );
                        checked += 1;
                        if ea != SURFACE_ALBEDO || er != SURFACE_ROUGHNESS || em != SURFACE_METALLIC {
                            covered += 1;
                        }
                    }
                }
                // (40 boxes leave fewer pixels clear of every face.)
                let enough = if count > 12 { 400 } else { 1500 };
                assert!(covered > enough, "seed {seed}: most checked pixels lie under decals ({covered} of {checked})");
                assert!(count < 40 || deepest > 32, "seed {seed}: some pixels are more than 32 decals deep (at most {deepest})");
                eprintln!("seed {seed}: {checked} pixels ({covered} under decals), worst abs error {worst:.5}");
            }
        }
    }
}

#[test]
fn unused_decal_lists_show_the_room_they_hold_and_forget_their_figures_when_released() {
    // The ray-tracing-pipeline pass's lists while another method runs: held (and shown) for a
    // second, then released with what they measured, so that the pass starts afresh when it
    // comes back rather than from figures two frames older than the release.
    let c = CONFIGS[2];
    let (mut app, _) = plane_app(c);
    let mut rng = Lcg(5);
    for _ in 0..3 {
        let t = downward(Vec3::new(rng.range(-0.5, 0.5), 0.0, rng.range(-0.5, 0.5)), Vec2::splat(2.0), 1.0, rng.next());
        let d = RefDecal {
            to_world: t.compute_matrix(),
            channel: 0,
            weight: 1.0,
            albedo: Some(Vec3::X),
            alpha: 1.0,
            roughness: None,
            metallic: None,
        };
        spawn_ref_decal(&mut app, &d);
    }
    for _ in 0..4 {
        app.update();
    }
    let used = counters(&app).decal_lists;
    assert!(used.measured_frame != u64::MAX && used.needed > 0 && used.capacity > 0, "the lists were measured: {used:?}");

    app.world.resource_mut::<RenderSettings>().decal_method = DecalMethod::Off;
    for _ in 0..render::gpu::upload::SHRINK_AFTER_FRAMES - 2 {
        app.update();
    }
    let unused = counters(&app).decal_lists;
    assert_eq!((unused.capacity, unused.shrinks), (used.capacity, used.shrinks), "held and shown while unused: {unused:?}");
    for _ in 0..4 {
        app.update();
    }
    let released = counters(&app).decal_lists;
    assert!(released.shrinks > used.shrinks, "released a second after the pass stopped: {released:?}");
    assert_eq!(
        (released.capacity, released.needed, released.overflowed, released.measured_frame),
        (0, 0, 0, u64::MAX),
        "a released buffer holds no room and forgets what it measured: {released:?}"
    );

    app.world.resource_mut::<RenderSettings>().decal_method = DecalMethod::RayPipeline;
    app.update();
    let back = counters(&app).decal_lists;
    assert_eq!(
        (back.capacity, back.measured_frame),
        (render::decals::lists::INITIAL_CAPACITY as u64, u64::MAX),
        "the pass comes back with the initial room and nothing measured yet: {back:?}"
    );
    for _ in 0..3 {
        app.update();
    }
    let again = counters(&app).decal_lists;
    assert!(again.measured_frame != u64::MAX && again.needed > 0, "measured again: {again:?}");
    assert_no_validation_errors(&mut app);
}

#[test]
fn the_order_of_overlapping_decals_within_a_channel_does_not_change_the_image() {
    // Eight translucent decals overlapping at the origin, in one channel with different weights,
    // spawned in one order and then in the reverse and a shuffled order (other slots, so other
    // primitive indices: the ray-tracing pipeline invokes any-hit shaders in another order, and
    // the ray query reports candidates in another).
    let mut rng = Lcg(11);
    let decals: Vec<RefDecal> = (0..8)
        .map(|i| RefDecal {
            to_world: downward(Vec3::new(rng.range(-0.3, 0.3), 0.0, rng.range(-0.3, 0.3)), Vec2::splat(2.0), 1.0, i as f32)
                .compute_matrix(),
            channel: 1,
            weight: rng.range(0.3, 3.0),
            albedo: Some(Vec3::new(rng.next(), rng.next(), rng.next())),
            alpha: rng.range(0.3, 0.8),
            roughness: Some(rng.next()),
            metallic: None,
        })
        .collect();
    let orders: [Vec<usize>; 3] = [(0..8).collect(), (0..8).rev().collect(), vec![3, 6, 0, 5, 2, 7, 1, 4]];
    for c in COVER {
        eprintln!("{c:?}");
        let mut images = Vec::new();
        for order in &orders {
            let (mut app, _) = plane_app(c);
            for &i in order {
                spawn_ref_decal(&mut app, &decals[i]);
            }
            let (albedo, rm) = read_views(&mut app);
            assert_no_validation_errors(&mut app);
            images.push((albedo, rm));
        }
        let (first_albedo, first_rm) = &images[0];
        for (albedo, rm) in &images[1..] {
            let diff = |a: &[[f32; 4]], b: &[[f32; 4]]| {
                a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs())).fold(0.0f32, f32::max)
            };
            let (da, dr) = (diff(first_albedo, albedo), diff(first_rm, rm));
            assert!(da <= 1e-3 && dr <= 1e-3, "{c:?}: another order changes the image by {da} (albedo), {dr} (roughness)");
        }
        // Not vacuous: at the origin all eight blend into something none of them is alone.
        let view = TopDownView::new(4.0, SIZE); // plane_app's view
        let (px, py) = pixel_of(&view, Vec3::ZERO);
        let got = Vec3::from_slice(&first_albedo[(py * SIZE.0 + px) as usize][..3]);
        let (expected, _, _) = reference(Vec3::ZERO, &decals);
        assert!((got - expected).abs().max_element() < 2e-3, "{c:?}: {got} vs the CPU reference {expected}");
        assert!(decals.iter().all(|d| (d.albedo.unwrap() - got).abs().max_element() > 0.02), "a blend, not one decal on top");
    }
}

/// One opaque red decal; returns whether each checked pixel shows it, compared with whether its
/// centre lies inside `inside(p)` (pixels within `margin` world units of the boundary skipped).
fn check_single_decal(app: &mut App, view: &TopDownView, inside: impl Fn(Vec3) -> Option<bool>) -> (usize, usize) {
    let (albedo, _) = read_views(app);
    assert_no_validation_errors(app);
    let (mut hits, mut misses) = (0, 0);
    for py in 0..SIZE.1 {
        for px in 0..SIZE.0 {
            let Some(p) = view.ground_point(px, py, 0.0) else { continue };
            let Some(expected) = inside(p) else { continue };
            let got = Vec3::from_slice(&albedo[(py * SIZE.0 + px) as usize][..3]);
            let shows = (got - Vec3::new(1.0, 0.0, 0.0)).abs().max_element() < 2e-3;
            let plain = (got - SURFACE_ALBEDO).abs().max_element() < 2e-3;
            assert!(shows || plain, "pixel ({px},{py}) is neither decal nor surface: {got}");
            assert_eq!(shows, expected, "pixel ({px},{py}) at {p}: decal shown {shows}, expected {expected}");
            if expected { hits += 1 } else { misses += 1 }
        }
    }
    (hits, misses)
}

fn red_material(app: &mut App) -> Handle<DecalMaterial> {
    app.world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(Vec4::new(1.0, 0.0, 0.0, 1.0)), ..Default::default() })
}

#[test]
fn containment_follows_the_oriented_box_at_faces_and_corners() {
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let material = red_material(&mut app);
        let transform = downward(Vec3::new(0.3, 0.0, -0.2), Vec2::new(2.0, 1.2), 1.0, 0.5);
        let to_decal = transform.compute_matrix().inverse();
        app.world.spawn((Decal::new(material), transform));
        let pixel = 2.0 * 4.0 * (view.camera.fov_y * 0.5).tan() / SIZE.1 as f32;
        let margin = 0.75 * pixel;
        let (hits, misses) = check_single_decal(&mut app, &view, |p| {
            let local = to_decal.transform_point3(p);
            // Distance outside (>0) or inside (<0) the box's x/y extent, in world units.
            let dx = (local.x.abs() - 0.5) * 2.0;
            let dy = (local.y.abs() - 0.5) * 1.2;
            let d = dx.max(dy);
            (d.abs() > margin).then_some(d < 0.0)
        });
        assert!(hits > 400 && misses > 400, "both sides checked: {hits} inside, {misses} outside");

        // Corners: points just inside each corner show the decal, points just outside do not.
        let (albedo, _) = read_views(&mut app);
        let m = transform.compute_matrix();
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            for (scale, expected) in [(0.42, true), (0.58, false)] {
                let p = m.transform_point3(Vec3::new(sx * scale, sy * scale, 0.0));
                let (px, py) = pixel_of(&view, p);
                let got = Vec3::from_slice(&albedo[(py * SIZE.0 + px) as usize][..3]);
                assert_eq!(got.x > 0.9 && got.y < 0.1, expected, "corner ({sx},{sy}) at scale {scale}: {got}");
            }
        }
        assert_eq!(reported_surface(&app), expected_surface(c, false), "{c:?}: default layers, no skin");
    }
}

/// The pixel whose centre is nearest to ground point `p`.
fn pixel_of(view: &TopDownView, p: Vec3) -> (u32, u32) {
    let mut best = (0, 0, f32::INFINITY);
    for py in 0..SIZE.1 {
        for px in 0..SIZE.0 {
            if let Some(q) = view.ground_point(px, py, 0.0) {
                let d = q.distance(p);
                if d < best.2 {
                    best = (px, py, d);
                }
            }
        }
    }
    (best.0, best.1)
}

#[test]
fn the_projection_depth_bounds_the_decal() {
    for c in COVER {
        eprintln!("{c:?}");
        // The box spans y in [0.1, 1.1]: the plane at y = 0 lies below its bottom face.
        let (mut app, view) = plane_app(c);
        let material = red_material(&mut app);
        app.world.spawn((Decal::new(material), downward(Vec3::new(0.0, 0.6, 0.0), Vec2::splat(2.0), 1.0, 0.0)));
        let (hits, misses) = check_single_decal(&mut app, &view, |_| Some(false));
        assert_eq!(hits, 0);
        assert!(misses > 5000);
        // Lowered so the plane is 0.05 inside the bottom face: now it shows.
        let decal = app.world.query_filtered::<Entity, With<Decal>>().single(&app.world).unwrap();
        app.world.get_mut::<Transform>(decal).unwrap().translation.y = 0.45;
        let (hits, _) = check_single_decal(&mut app, &view, |p| {
            (p.x.abs().max(p.z.abs()) - 1.0).abs().gt(&0.06).then_some(p.x.abs().max(p.z.abs()) < 1.0)
        });
        assert!(hits > 500);
    }
}

#[test]
fn receiver_masks_keep_decals_off_other_layers() {
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        // A second, raised plane on the right half that only receives layer 2.
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(3.0, 6.0, 1, 1.0));
        let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(
            SURFACE_ALBEDO.extend(1.0),
            SURFACE_METALLIC,
            SURFACE_ROUGHNESS,
        ));
        app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(1.5, 0.05, 0.0), DecalReceiver(2)));
        let red = red_material(&mut app);
        let mut decal = Decal::new(red);
        decal.receivers = 1; // the ground's default layer only
        app.world.spawn((decal, downward(Vec3::ZERO, Vec2::splat(2.4), 1.0, 0.0)));
        let (hits, misses) = check_single_decal(&mut app, &view, |p| {
            let inside = p.x.abs() < 1.2 && p.z.abs() < 1.2;
            let near_edge = (p.x.abs() - 1.2).abs() < 0.06 || (p.z.abs() - 1.2).abs() < 0.06 || p.x.abs() < 0.06;
            // Right of x = 0 the raised plane (layer 2) covers the ground.
            (!near_edge).then_some(inside && p.x < 0.0)
        });
        assert!(hits > 300 && misses > 300, "{hits} {misses}");
        assert_eq!(reported_surface(&app), expected_surface(c, true), "{c:?}: the raised plane's layers need the ids");
    }
}

#[test]
fn angle_fade_follows_the_angle_between_surface_and_projection_axis() {
    for c in COVER {
        eprintln!("{c:?}");
        // One app a configuration: each tilt's decal replaces the last.
        let (mut app, view) = plane_app(c);
        let material = red_material(&mut app);
        let mut last: Option<Entity> = None;
        for (tilt_deg, expected_alpha) in [(20.0f32, 1.0f32), (45.0, 0.5), (70.0, 0.0)] {
            if let Some(old) = last.take() {
                app.world.despawn(old);
            }
            let mut decal = Decal::new(material);
            // Fade linear in cos θ between 30° and 60°: at 45° halfway in cos.
            decal.angle_fade = Some(AngleFade { start: 30f32.to_radians(), end: 60f32.to_radians() });
            let tilt = Quat::from_rotation_z(tilt_deg.to_radians());
            let t = Transform::from_translation(Vec3::ZERO)
                .with_rotation(tilt * Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
                .with_scale(Vec3::new(1.5, 1.5, 1.5));
            last = Some(app.world.spawn((decal, t)).id());
            let (albedo, _) = read_views(&mut app);
            assert_no_validation_errors(&mut app);
            let cos = tilt_deg.to_radians().cos();
            let (c30, c60) = (30f32.to_radians().cos(), 60f32.to_radians().cos());
            let alpha = ((cos - c60) / (c30 - c60)).clamp(0.0, 1.0);
            assert!((alpha - expected_alpha).abs() < 0.2, "test setup: {alpha}");
            let (px, py) = pixel_of(&view, Vec3::ZERO);
            let got = Vec3::from_slice(&albedo[(py * SIZE.0 + px) as usize][..3]);
            let expected = Vec3::new(1.0, 0.0, 0.0) * alpha + SURFACE_ALBEDO * (1.0 - alpha);
            assert!((got - expected).abs().max_element() < 2e-3, "tilt {tilt_deg}°: got {got}, expected {expected}");
        }
    }
}

fn counters(app: &App) -> render::FrameCounters {
    app.world.resource::<RenderStats>().last
}

/// Whether the pixel nearest `p` shows the red decal (albedo view must be active).
fn shows_red_at(app: &mut App, view: &TopDownView, p: Vec3) -> bool {
    let hdr = renderer(app).read_hdr().unwrap();
    let (px, py) = pixel_of(view, p);
    let got = &hdr[(py * SIZE.0 + px) as usize];
    got[0] > 0.9 && got[1] < 0.1
}

#[test]
fn ecs_sequences_give_the_expected_image_and_the_expected_work() {
    for config in COVER {
        eprintln!("{config:?}");
        let (mut app, view) = plane_app(config);
        let red = red_material(&mut app);
        // Acceleration-structure work happens only for ray-traced methods; clustered decals
        // bin the same uploaded boxes on the GPU and build nothing.
        let k = config.method.traces() as u64;
        let record_bytes = (std::mem::size_of::<render::scene::GpuDecal>() + std::mem::size_of::<render::scene::GpuAabb>()) as u64;

        // Spawn 10 decals in a row, plus one riding on a parent.
        let decals: Vec<Entity> = (0..10)
            .map(|i| {
                app.world.spawn((Decal::new(red), downward(Vec3::new(-1.8 + i as f32 * 0.4, 0.0, -1.0), Vec2::splat(0.25), 1.0, 0.0))).id()
            })
            .collect();
        let parent = app.world.spawn(Transform::from_xyz(0.0, 0.0, 1.0)).id();
        app.world.spawn((Decal::new(red), downward(Vec3::ZERO, Vec2::splat(0.3), 1.0, 0.0), ChildOf(parent)));
        app.update();
        let c = counters(&app);
        assert_eq!((c.blas_builds, c.blas_updates, c.tlas_builds, c.decals), (k, 0, k, 11), "first frame builds: {c:?}");
        assert!(shows_red_at(&mut app, &view, Vec3::new(-1.8, 0.0, -1.0)));
        assert!(shows_red_at(&mut app, &view, Vec3::new(0.0, 0.0, 1.0)), "the child decal sits under its parent");

        // Nothing changes: no bytes, no acceleration-structure work.
        app.update();
        let c = counters(&app);
        assert_eq!((c.bytes_uploaded, c.records_written, c.blas_builds, c.blas_updates, c.tlas_builds), (0, 0, 0, 0, 0), "{c:?}");

        // Move one decal: one record and one box uploaded, a refit, a TLAS build; the image follows.
        app.world.get_mut::<Transform>(decals[0]).unwrap().translation = Vec3::new(-1.8, 0.0, 0.3);
        app.update();
        let c = counters(&app);
        assert_eq!(
            (c.records_written, c.bytes_uploaded, c.blas_builds, c.blas_updates, c.tlas_builds),
            (1, record_bytes, 0, k, k),
            "{c:?}"
        );
        assert!(shows_red_at(&mut app, &view, Vec3::new(-1.8, 0.0, 0.3)));
        assert!(!shows_red_at(&mut app, &view, Vec3::new(-1.8, 0.0, -1.0)), "the old place is clear");

        // Move the parent: its child decal follows, by refit.
        app.world.get_mut::<Transform>(parent).unwrap().translation = Vec3::new(1.2, 0.0, 1.0);
        app.update();
        let c = counters(&app);
        assert_eq!((c.records_written, c.blas_updates, c.blas_builds), (1, k, 0), "{c:?}");
        assert!(shows_red_at(&mut app, &view, Vec3::new(1.2, 0.0, 1.0)));
        assert!(!shows_red_at(&mut app, &view, Vec3::new(0.0, 0.0, 1.0)));

        // Despawn two: their slots empty by refit, the image clears.
        let freed: Vec<u32> = decals[3..5].iter().map(|&e| app.world.resource::<MirrorSlots>().decal(e).unwrap()).collect();
        app.world.despawn(decals[3]);
        app.world.despawn(decals[4]);
        app.update();
        let c = counters(&app);
        assert_eq!((c.decals, c.blas_updates, c.blas_builds), (9, k, 0), "{c:?}");
        assert!(!shows_red_at(&mut app, &view, Vec3::new(-1.8 + 3.0 * 0.4, 0.0, -1.0)));

        // Respawn into the freed slots: still a refit, not a build.
        let respawned: Vec<Entity> = (0..2)
            .map(|i| app.world.spawn((Decal::new(red), downward(Vec3::new(-1.0 + i as f32, 0.0, 0.0), Vec2::splat(0.3), 1.0, 0.0))).id())
            .collect();
        app.update();
        let c = counters(&app);
        let mut reused: Vec<u32> = respawned.iter().map(|&e| app.world.resource::<MirrorSlots>().decal(e).unwrap()).collect();
        reused.sort();
        let mut freed_sorted = freed.clone();
        freed_sorted.sort();
        assert_eq!(reused, freed_sorted, "new decals take the freed slots");
        assert_eq!((c.decals, c.blas_updates, c.blas_builds), (11, k, 0), "{c:?}");
        assert!(shows_red_at(&mut app, &view, Vec3::new(0.0, 0.0, 0.0)));

        // Growing past the built range (64 boxes) rebuilds, once.
        for i in 0..60 {
            app.world.spawn((Decal::new(red), downward(Vec3::new(-2.0 + (i % 10) as f32 * 0.1, 0.0, 1.6), Vec2::splat(0.05), 1.0, 0.0)));
        }
        app.update();
        let c = counters(&app);
        assert_eq!((c.decals, c.blas_builds, c.blas_updates, c.tlas_builds), (71, k, 0, k), "{c:?}");
        app.update();
        let c = counters(&app);
        assert_eq!((c.blas_builds, c.blas_updates, c.tlas_builds, c.bytes_uploaded), (0, 0, 0, 0), "{c:?}");
        assert_no_validation_errors(&mut app);
    }
}

#[test]
fn lifetimes_fade_decals_out_on_the_gpu_clock_and_despawn_them_on_time() {
    // Headless ECS: 60 frames per second, a 1 s lifetime fading over its last 0.5 s, among
    // decals without lifetimes.
    let mut app = tests::ecs_app();
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_secs_f64(1.0 / 60.0)));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 3.0)));
    for i in 0..10 {
        app.world.spawn((Decal::new(material), Transform::from_xyz(i as f32, 0.0, 0.0)));
    }
    let e = app.world.spawn((Decal::new(material), Transform::default(), DecalLifetime::new(1.0, 0.5))).id();
    let mut seen = Vec::new();
    for frame in 1..=70 {
        app.update();
        let records = app.world.resource::<RenderMirror>().0.records_written;
        let visited = app.world.resource::<RenderStats>().visited.decals;
        if app.world.get_entity(e).is_err() {
            seen.push((frame, None, records, visited));
            break;
        }
        seen.push((frame, tests::decal_opacity_in_mirror(&app, e), records, visited));
    }
    let at = |f: usize| seen[f - 1];
    let opacity_at = |f: usize| at(f).1.expect("alive");
    assert_eq!(opacity_at(10), 1.0, "full opacity before the fade");
    assert!((opacity_at(45) - 0.5).abs() < 0.05, "halfway through the fade: {}", opacity_at(45));
    assert!(opacity_at(59) < 0.05);
    // Ageing writes nothing: no decal record, and the camera's clock only while a decal fades.
    for f in 2..=29 {
        assert_eq!((at(f).2, at(f).3), (0, 0), "frame {f}: nothing written, no decal visited while the decals only age");
    }
    for f in 32..=58 {
        assert_eq!((at(f).2, at(f).3), (1, 0), "frame {f}: only the camera's clock is written during the fade");
    }
    let (last_frame, state, _, _) = *seen.last().unwrap();
    assert_eq!(state, None, "despawned");
    assert!((60..=61).contains(&last_frame), "despawned after 1 s, at frame {last_frame}");
    assert_eq!(app.world.resource::<RenderMirror>().0.decals.len(), 10, "its slot is freed, the others stay");
    app.update();
    assert_eq!(app.world.resource::<RenderMirror>().0.records_written, 0, "the clock stops once nothing fades");
}

#[test]
fn decals_with_non_finite_or_singular_transforms_land_nowhere_and_the_rest_still_show() {
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let red = red_material(&mut app);
        let bad = [
            Transform::from_xyz(f32::NAN, 0.0, 0.0),
            Transform::from_xyz(0.0, 0.0, 0.0).with_scale(Vec3::new(f32::INFINITY, 1.0, 1.0)),
            Transform::from_xyz(0.5, 0.0, 0.5).with_scale(Vec3::ZERO),
            downward(Vec3::new(-0.5, 0.0, 0.5), Vec2::new(1.0, 0.0), 1.0, 0.0),
        ];
        for t in bad {
            app.world.spawn((Decal::new(red), t));
        }
        let good = app.world.spawn((Decal::new(red), downward(Vec3::new(1.2, 0.0, -0.6), Vec2::splat(0.6), 1.0, 0.0))).id();
        app.update();
        let albedo = renderer(&mut app).read_hdr().unwrap();
        assert_no_validation_errors(&mut app);
        assert_eq!(counters(&app).decals, 5, "invalid decals keep their slots");
        assert!(albedo.iter().all(|p| p.iter().all(|v| v.is_finite())), "{c:?}: no pixel is NaN or infinite");
        assert!(shows_red_at(&mut app, &view, Vec3::new(1.2, 0.0, -0.6)), "{c:?}: the valid decal shows");
        assert!(!shows_red_at(&mut app, &view, Vec3::new(0.5, 0.0, 0.5)), "{c:?}: a zero-scale decal shows nowhere");
        assert!(!shows_red_at(&mut app, &view, Vec3::new(-0.5, 0.0, 0.5)), "{c:?}: a flat decal shows nowhere");
        // A decal that becomes valid shows, and one that becomes invalid vanishes.
        app.world.get_mut::<Transform>(good).unwrap().scale = Vec3::ZERO;
        app.update();
        assert!(!shows_red_at(&mut app, &view, Vec3::new(1.2, 0.0, -0.6)), "{c:?}: the decal became singular");
        *app.world.get_mut::<Transform>(good).unwrap() = downward(Vec3::new(1.2, 0.0, -0.6), Vec2::splat(0.6), 1.0, 0.0);
        app.update();
        assert!(shows_red_at(&mut app, &view, Vec3::new(1.2, 0.0, -0.6)), "{c:?}: and valid again");
        assert_no_validation_errors(&mut app);
    }
}

#[test]
fn ten_thousand_decals_render_without_validation_errors() {
    for c in COVER {
        eprintln!("{c:?}");
        let mut app = config_app(c, (64, 48), DebugView::Albedo);
        let view = TopDownView::new(4.0, (64, 48));
        view.spawn(&mut app.world);
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
        let material = app.world.resource_mut::<Assets<Material>>().add(Material::default());
        app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
        let red = red_material(&mut app);
        let mut rng = Lcg(7);
        let batch: Vec<_> = (0..10_000)
            .map(|_| {
                (
                    Decal::new(red),
                    downward(
                        Vec3::new(rng.range(-3.0, 3.0), 0.0, rng.range(-2.0, 2.0)),
                        Vec2::splat(rng.range(0.05, 0.2)),
                        0.5,
                        rng.range(0.0, 6.3),
                    ),
                )
            })
            .collect();
        app.world.spawn_batch(batch);
        app.update();
        app.update();
        let c = counters(&app);
        assert_eq!(c.decals, 10_000);
        let albedo = renderer(&mut app).read_hdr().unwrap();
        let red = albedo.iter().filter(|p| p[0] > 0.9 && p[1] < 0.1).count();
        assert!(red > albedo.len() / 4, "decals cover much of the plane: {red} of {} pixels", albedo.len());
        assert_no_validation_errors(&mut app);
    }
}

#[test]
fn debug_views_show_boxes_and_count_the_decals_tested_per_pixel() {
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let red = red_material(&mut app);
        // Three boxes that overlap at the origin; the rotated one's AABB is larger than its box.
        for (x, yaw) in [(-0.3f32, 0.0f32), (0.3, 0.0), (0.0, 0.7)] {
            app.world.spawn((Decal::new(red), downward(Vec3::new(x, 0.0, 0.0), Vec2::splat(1.0), 1.0, yaw)));
        }
        app.world.resource_mut::<RenderSettings>().debug_view = DebugView::DecalCount;
        app.update();
        let counts = renderer(&mut app).read_hdr().unwrap();
        let at = |p: Vec3| {
            let (px, py) = pixel_of(&view, p);
            counts[(py * SIZE.0 + px) as usize][0]
        };
        assert_eq!(at(Vec3::ZERO), 3.0, "all three AABBs hold the origin");
        assert_eq!(at(Vec3::new(1.9, 0.0, 1.5)), 0.0, "nothing far away");
        if c.method == DecalMethod::Clustered {
            // Clustered decals test every decal of the pixel's cluster (a 32-pixel tile, here
            // about 1.2 m of ground, × a depth slice): all three boxes' AABBs touch the
            // origin's cluster.
            assert_eq!(at(Vec3::new(-0.75, 0.0, 0.0)), 3.0, "the cluster's list");
        } else {
            assert_eq!(at(Vec3::new(-0.75, 0.0, 0.0)), 1.0, "only the left box");
        }

        let mut settings = app.world.resource_mut::<RenderSettings>();
        settings.debug_view = DebugView::Albedo;
        settings.show_decal_boxes = true;
        app.update();
        let hdr = renderer(&mut app).read_hdr().unwrap();
        let green = hdr.iter().filter(|p| p[1] > 0.9 && p[0] < 0.2 && p[2] < 0.3).count();
        let yellow = hdr.iter().filter(|p| p[0] > 0.9 && p[1] > 0.8 && p[2] < 0.2).count();
        assert!(green > 100, "oriented boxes drawn: {green} pixels");
        assert!(yellow > 50, "AABBs drawn: {yellow} pixels");
        assert_no_validation_errors(&mut app);
    }
}

/// Every pixel enumerates each decal whose box (its AABB, the acceleration structure's
/// primitive) holds the pixel's surface point exactly once: the count view equals a CPU count of
/// the boxes holding the point, over 24 overlapping boxes, on both ray-tracing tiers (pixels
/// within 2 cm of a box face are left out: the surface point is reconstructed from depth). The
/// ray-tracing-pipeline pass's count-only floor (`DebugView::DecalFloor`) counts the oriented
/// boxes holding the point, and applies nothing.
#[test]
fn every_pixel_enumerates_each_decal_box_holding_it_once() {
    for c in COVER.into_iter().filter(|c| c.method != DecalMethod::Clustered) {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let red = red_material(&mut app);
        let mut rng = Lcg(11);
        let (mut boxes, mut oriented) = (Vec::new(), Vec::new());
        for _ in 0..24 {
            let centre = Vec3::new(rng.range(-1.5, 1.5), 0.0, rng.range(-1.1, 1.1));
            let size = Vec2::new(rng.range(0.3, 1.2), rng.range(0.3, 1.2));
            let t = downward(centre, size, rng.range(0.3, 1.0), rng.range(0.0, 3.0));
            let m = t.compute_matrix();
            let corners = (0..8).map(|i| {
                m.transform_point3(Vec3::new(
                    if i & 1 == 0 { -0.5 } else { 0.5 },
                    if i & 2 == 0 { -0.5 } else { 0.5 },
                    if i & 4 == 0 { -0.5 } else { 0.5 },
                ))
            });
            let (lo, hi) = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
            boxes.push((lo, hi));
            oriented.push(m.inverse());
            app.world.spawn((Decal::new(red), t));
        }
        app.world.resource_mut::<RenderSettings>().debug_view = DebugView::DecalCount;
        app.update();
        let counts = renderer(&mut app).read_hdr().unwrap();
        assert_no_validation_errors(&mut app);
        let (mut checked, mut most) = (0, 0);
        for py in 0..SIZE.1 {
            for px in 0..SIZE.0 {
                let Some(p) = view.ground_point(px, py, 0.0) else { continue };
                let near_face = |(lo, hi): &(Vec3, Vec3)| (0..3).any(|a| (p[a] - lo[a]).abs() < 0.02 || (p[a] - hi[a]).abs() < 0.02);
                if boxes.iter().any(near_face) {
                    continue;
                }
                let expected = boxes.iter().filter(|(lo, hi)| p.cmpge(*lo).all() && p.cmple(*hi).all()).count();
                let got = counts[(py * SIZE.0 + px) as usize][0];
                assert_eq!(got, expected as f32, "{c:?}: pixel ({px},{py}) at {p}");
                checked += 1;
                most = most.max(expected);
            }
        }
        assert!(checked > (SIZE.0 * SIZE.1 / 4) as usize && most >= 4, "{checked} pixels checked, at most {most} boxes deep");
        if c.method != DecalMethod::RayPipeline {
            continue;
        }
        app.world.resource_mut::<RenderSettings>().debug_view = DebugView::DecalFloor;
        app.update();
        let floor = renderer(&mut app).read_hdr().unwrap();
        for _ in 0..3 {
            app.update(); // the timestamps come back a few frames later
        }
        let stats = app.world.resource::<plugins::RenderStats>();
        let frame = stats.completed.back().expect("frames with GPU times");
        assert!(
            frame.gpu.get("decal_pass_floor").is_some() && frame.gpu.get("decal_pass_ray_pipeline").is_none(),
            "{c:?}: the floor replaces the lit pass"
        );
        assert_no_validation_errors(&mut app);
        let (mut checked, mut most) = (0, 0);
        for py in 0..SIZE.1 {
            for px in 0..SIZE.0 {
                let Some(p) = view.ground_point(px, py, 0.0) else { continue };
                let local: Vec<Vec3> = oriented.iter().map(|m| m.transform_point3(p)).collect();
                if local.iter().any(|l| (0..3).any(|a| (l[a].abs() - 0.5).abs() < 0.03)) {
                    continue;
                }
                let expected = local.iter().filter(|l| l.abs().cmple(Vec3::splat(0.5)).all()).count();
                assert_eq!(floor[(py * SIZE.0 + px) as usize][0], expected as f32, "{c:?} floor: pixel ({px},{py}) at {p}");
                checked += 1;
                most = most.max(expected);
            }
        }
        assert!(checked > (SIZE.0 * SIZE.1 / 4) as usize && most >= 3, "floor: {checked} pixels checked, at most {most} boxes deep");
    }
}

#[test]
fn decal_normal_maps_rotate_with_the_decal() {
    for c in COVER {
        eprintln!("{c:?}");
        // A constant tangent-space normal tilted towards +X (decal space): (0.6, 0, 0.8).
        let texel = [((0.6f32 * 0.5 + 0.5) * 255.0).round() as u8, 128, ((0.8f32 * 0.5 + 0.5) * 255.0).round() as u8, 255];
        let ts = Vec3::new(texel[0] as f32, texel[1] as f32, texel[2] as f32) / 255.0 * 2.0 - 1.0;
        // One app a configuration: each yaw's decal replaces the last.
        let (mut app, view) = plane_app(c);
        let image = Image::from_rgba8(4, 4, texel.repeat(16), ColorSpace::Linear).unwrap();
        let image = app.world.resource_mut::<Assets<Image>>().add(image);
        let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial {
            base_color: None,
            normal_texture: Some(image),
            ..Default::default()
        });
        app.world.resource_mut::<RenderSettings>().debug_view = DebugView::Normal;
        let mut last: Option<Entity> = None;
        for yaw in [0.0f32, std::f32::consts::FRAC_PI_2, 2.3] {
            if let Some(old) = last.take() {
                app.world.despawn(old);
            }
            last = Some(app.world.spawn((Decal::new(material), downward(Vec3::ZERO, Vec2::splat(1.5), 1.0, yaw))).id());
            app.update();
            let hdr = renderer(&mut app).read_hdr().unwrap();
            assert_no_validation_errors(&mut app);
            let (px, py) = pixel_of(&view, Vec3::ZERO);
            let got = Vec3::from_slice(&hdr[(py * SIZE.0 + px) as usize][..3]) * 2.0 - 1.0;
            // Decal x in world is the yawed +X; decal y (image up) the yawed −Z; the surface normal +Y.
            let t = Quat::from_rotation_y(yaw) * Vec3::X;
            let b = Quat::from_rotation_y(yaw) * Vec3::NEG_Z;
            let expected = (t * ts.x + b * ts.y + Vec3::Y * ts.z).normalize();
            assert!((got - expected).length() < 4e-3, "yaw {yaw}: normal {got}, expected {expected}");
            // Outside the decal the plane's own normal remains.
            let (px, py) = pixel_of(&view, Vec3::new(1.9, 0.0, 1.4));
            let plain = Vec3::from_slice(&hdr[(py * SIZE.0 + px) as usize][..3]) * 2.0 - 1.0;
            assert!((plain - Vec3::Y).length() < 2e-3, "{plain}");
        }
    }
}

#[test]
fn decal_textures_are_sampled_at_the_mip_level_their_footprint_needs() {
    // A 64×64 texture whose levels are told apart by colour: level 0 red, 1 green, 2 blue, the
    // rest white. Seen from above, a decal S metres wide maps 64 × (pixel size) / S texels to a
    // pixel, so sizes giving 1, 2 and 4 texels a pixel must sample levels 0, 1 and 2: the
    // footprint is analytic (from depth in the decal pass, from quad derivatives in the forward
    // shader), never the finest level everywhere.
    let level_colors: [[u8; 4]; 3] = [[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255]];
    let mips: Vec<Vec<u8>> = (0..7u32)
        .map(|level| {
            let texels = ((64 >> level) * (64 >> level)) as usize;
            level_colors.get(level as usize).copied().unwrap_or([255; 4]).repeat(texels)
        })
        .collect();
    let image = Image { width: 64, height: 64, color_space: ColorSpace::Linear, format: engine::image::TexelFormat::Rgba8, mips };
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let pixel_world = 2.0 * view.transform.translation.y * (view.camera.fov_y * 0.5).tan() / SIZE.1 as f32;
        let texture = app.world.resource_mut::<Assets<Image>>().add(image.clone());
        let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial {
            base_color_texture: Some(texture),
            base_color: Some(Vec4::ONE),
            ..Default::default()
        });
        let centres = [Vec3::new(-1.3, 0.0, 0.0), Vec3::new(0.2, 0.0, 0.0), Vec3::new(1.4, 0.0, 0.0)];
        for (level, centre) in centres.iter().enumerate() {
            let size = 64.0 * pixel_world / (1u32 << level) as f32;
            app.world.spawn((Decal::new(material), downward(*centre, Vec2::splat(size), 1.0, 0.0)));
        }
        let (albedo, _) = read_views(&mut app);
        assert_no_validation_errors(&mut app);
        for (level, centre) in centres.iter().enumerate() {
            let (px, py) = pixel_of(&view, *centre);
            let got = Vec3::from_slice(&albedo[(py * SIZE.0 + px) as usize][..3]);
            assert!(got[level] > 0.7 && (0..3).all(|k| k == level || got[k] < 0.3), "{c:?}: a decal at level {level} shows {got}");
        }
    }
}

/// Where the game wants a bullet hole: a gameplay event a system reads.
#[derive(Resource, Default)]
struct ShotAt(Option<Vec3>);

/// An ordinary gameplay system: spawns a bullet hole with `Commands` wherever it was told.
fn shoot(mut commands: Commands, mut shot: ResMut<ShotAt>, holes: Res<BulletHole>) {
    if let Some(hit) = shot.0.take() {
        let transform = Transform::from_translation(hit)
            .looking_at(hit - Vec3::Y, Vec3::NEG_Z) // local −Z into the ground
            .with_scale(Vec3::new(0.6, 0.6, 0.3));
        commands.spawn((Decal::new(holes.0), transform));
    }
}

#[derive(Resource)]
struct BulletHole(Handle<DecalMaterial>);

#[test]
fn a_gameplay_system_spawns_a_bullet_hole_that_shows_in_the_same_frame() {
    for c in COVER {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        let set = sandbox::decal_textures::bullet_hole();
        let material = sandbox::decal_textures::decal_material(&set, &mut app.world);
        let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(material);
        app.insert_resource(BulletHole(material)).insert_resource(ShotAt::default());
        app.add_systems(Update, shoot);
        app.update();
        let before = renderer(&mut app).read_hdr().unwrap();

        let target = Vec3::new(0.8, 0.0, -0.5);
        app.world.resource_mut::<ShotAt>().0 = Some(target);
        app.update();
        let after = renderer(&mut app).read_hdr().unwrap();
        assert_no_validation_errors(&mut app);
        assert_eq!(app.world.resource::<RenderStats>().last.decals, 1);
        let (px, py) = pixel_of(&view, target);
        let i = (py * SIZE.0 + px) as usize;
        let darkening = Vec3::from_slice(&before[i][..3]).length() - Vec3::from_slice(&after[i][..3]).length();
        assert!(darkening > 0.2, "the burnt centre of the hole darkens the albedo: before {:?} after {:?}", before[i], after[i]);
        let (fx, fy) = pixel_of(&view, target + Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(before[(fy * SIZE.0 + fx) as usize], after[(fy * SIZE.0 + fx) as usize], "1 m away nothing changed");
    }
}

#[test]
fn decals_fade_with_distance_by_their_own_fade_or_the_global_default() {
    // The camera is 4 m above the plane: a decal centred at (x, 0, z) is sqrt(16 + x² + z²) m
    // away. One fades over 3..5 m (at 4.12 m: (5 − 4.12) / 2 = 0.44 of its colour); one is
    // exempt from the global 1..2 m fade; one takes it and has vanished. Every method: the
    // configurations above and the deferred decals.
    let deferred_decals = Config { tier: Tier::NoRayTracing, pipeline: PipelineKind::Deferred, method: DecalMethod::DeferredDecals };
    for c in COVER.into_iter().chain([deferred_decals]) {
        eprintln!("{c:?}");
        let (mut app, view) = plane_app(c);
        app.world.resource_mut::<RenderSettings>().decal_distance_fade = Some(DistanceFade { start: 1.0, end: 2.0 });
        let red = red_material(&mut app);
        let spots = [Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];
        let fades = [Some(DistanceFade { start: 3.0, end: 5.0 }), Some(DistanceFade::NEVER), None];
        for (&at, fade) in spots.iter().zip(fades) {
            app.world.spawn((Decal { distance_fade: fade, ..Decal::new(red) }, downward(at, Vec2::splat(0.3), 1.0, 0.0)));
        }
        app.update();
        let albedo = renderer(&mut app).read_hdr().unwrap();
        assert_no_validation_errors(&mut app);
        let at = |p: Vec3| {
            let (px, py) = view.pixel_of(p);
            albedo[(py * SIZE.0 + px) as usize]
        };
        let s = SURFACE_ALBEDO.x;
        let a = (5.0 - 17f32.sqrt()) / 2.0;
        let faded = at(spots[0]);
        assert!((faded[0] - (s + (1.0 - s) * a)).abs() < 0.02 && (faded[1] - s * (1.0 - a)).abs() < 0.02, "{faded:?} for {a}");
        let exempt = at(spots[1]);
        assert!(exempt[0] > 0.97 && exempt[1] < 0.03, "never fades: {exempt:?}");
        let gone = at(spots[2]);
        assert!((gone[0] - s).abs() < 0.01 && (gone[1] - s).abs() < 0.01, "faded out by the global default: {gone:?}");
    }
}

#[test]
fn emissive_decals_add_light_above_one_before_tone_mapping_through_the_blend() {
    // An albedo decal and an emissive one (no albedo, weight 3) overlap in channel 0 over an
    // unlit plane: the emissive one adds its radiance × coverage (blend.glsl: decals add light)
    // and leaves the albedo blend as it was, so despawning it takes exactly that radiance away.
    // Every method: the configurations above, the ray-query compute pass, the deferred decals
    // and the clustered decals walked in the forward shading.
    let extra = [
        Config { tier: Tier::RayQuery, pipeline: PipelineKind::Deferred, method: DecalMethod::RayQueryCompute },
        Config { tier: Tier::NoRayTracing, pipeline: PipelineKind::Deferred, method: DecalMethod::DeferredDecals },
    ];
    let radiance = Vec3::new(5.0, 2.0, 1.0);
    let coverage = 0.6;
    for (c, in_forward_shading) in COVER.into_iter().map(|c| (c, false)).chain(extra.map(|c| (c, false))).chain([(CONFIGS[4], true)]) {
        eprintln!("{c:?}, in forward shading: {in_forward_shading}");
        let (mut app, view) = plane_app(c);
        {
            let mut settings = app.world.resource_mut::<RenderSettings>();
            settings.debug_view = DebugView::Lit;
            settings.decals_in_forward_shading = in_forward_shading;
        }
        let mut materials = app.world.resource_mut::<Assets<DecalMaterial>>();
        let paint = materials.add(DecalMaterial { base_color: Some(Vec4::new(0.2, 0.4, 0.6, 1.0)), ..Default::default() });
        let glow = materials.add(DecalMaterial { base_color: None, emissive: Some(radiance), ..Default::default() });
        let place = downward(Vec3::ZERO, Vec2::splat(1.0), 1.0, 0.0);
        app.world.spawn((Decal { opacity: 0.7, ..Decal::new(paint) }, place));
        let ember = app.world.spawn((Decal { opacity: coverage, weight: 3.0, ..Decal::new(glow) }, place)).id();
        app.update();
        let lit = renderer(&mut app).read_hdr().unwrap();
        app.world.despawn(ember);
        app.update();
        let unlit = renderer(&mut app).read_hdr().unwrap();
        assert_no_validation_errors(&mut app);
        let at = |image: &[[f32; 4]], p: Vec3| {
            let (px, py) = view.pixel_of(p);
            Vec3::from_slice(&image[(py * SIZE.0 + px) as usize][..3])
        };
        for p in [Vec3::ZERO, Vec3::new(0.3, 0.0, -0.2)] {
            let added = at(&lit, p) - at(&unlit, p);
            assert!((added - radiance * coverage).abs().max_element() < 0.02, "at {p}: added {added}, expected {}", radiance * coverage);
            assert!(at(&lit, p).max_element() > 1.0, "above 1 before tone mapping: {}", at(&lit, p));
        }
        let outside = Vec3::new(1.5, 0.0, 0.0);
        assert!((at(&lit, outside) - at(&unlit, outside)).abs().max_element() < 1e-3, "no light outside the box");
    }
}
