//! Ray-query decals on lavapipe: the blending equations against a CPU reference, containment at
//! the box's faces and corners, receiver masks, angle and lifetime fades, and ECS sequences whose
//! images *and* work counters are both checked.
//!
//! Scenes are a horizontal plane seen from straight above ([`TopDownView`]); the shading pass's
//! debug views write the post-decal albedo and roughness/metallic into the HDR target, which is
//! read back and compared per pixel. Pixels within one pixel footprint of any box edge are
//! skipped: there the GPU's interpolated position and our exact one may fall on different sides.

use engine::prelude::*;
use plugins::decal::{AngleFade, Decal, DecalLifetime, DecalMaterial, DecalReceiver};
use plugins::{MirrorSlots, RenderMirror, RenderSettings, RenderStats};
use render::DebugView;
use tests::{TopDownView, assert_no_validation_errors, gpu_app, renderer};

const SURFACE_ALBEDO: Vec3 = Vec3::new(0.5, 0.5, 0.5);
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
        let mut add = |acc: &mut Acc, v: Vec3| {
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
    (
        resolve(&albedo, SURFACE_ALBEDO),
        resolve(&rough, Vec3::splat(SURFACE_ROUGHNESS)).x,
        resolve(&metal, Vec3::splat(SURFACE_METALLIC)).x,
    )
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

fn plane_app() -> (App, TopDownView) {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { debug_view: DebugView::Albedo, ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(SURFACE_ALBEDO.extend(1.0), SURFACE_METALLIC, SURFACE_ROUGHNESS));
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

#[test]
fn random_overlapping_stacks_match_the_cpu_blending_reference() {
    for seed in [1u64, 2, 3] {
        let (mut app, view) = plane_app();
        let mut rng = Lcg(seed);
        let decals: Vec<RefDecal> = (0..12)
            .map(|_| {
                let t = downward(
                    Vec3::new(rng.range(-1.0, 1.0), 0.0, rng.range(-0.8, 0.8)),
                    Vec2::new(rng.range(1.5, 3.0), rng.range(1.5, 3.0)),
                    1.0,
                    rng.range(0.0, 6.28),
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
        for d in &decals {
            spawn_ref_decal(&mut app, d);
        }
        let (albedo, rm) = read_views(&mut app);
        assert_no_validation_errors(&mut app);

        let pixel_world = 2.0 * view.transform.translation.y * (view.camera.fov_y * 0.5).tan() / SIZE.1 as f32;
        let (mut checked, mut covered, mut worst) = (0, 0, 0.0f32);
        for py in 0..SIZE.1 {
            for px in 0..SIZE.0 {
                let Some(p) = view.ground_point(px, py, 0.0) else { continue };
                if distance_to_any_face(p, &decals) < pixel_world {
                    continue;
                }
                let (ea, er, em) = reference(p, &decals);
                let i = (py * SIZE.0 + px) as usize;
                let got_a = Vec3::from_slice(&albedo[i][..3]);
                let (got_r, got_m) = (rm[i][0], rm[i][1]);
                let err = (got_a - ea).abs().max_element().max((got_r - er).abs()).max((got_m - em).abs());
                worst = worst.max(err);
                assert!(err <= 1.5e-3, "seed {seed} pixel ({px},{py}) at {p}: gpu albedo {got_a} r {got_r} m {got_m}, cpu {ea} {er} {em}");
                checked += 1;
                if ea != SURFACE_ALBEDO || er != SURFACE_ROUGHNESS || em != SURFACE_METALLIC {
                    covered += 1;
                }
            }
        }
        assert!(covered > 1500, "seed {seed}: most checked pixels lie under decals ({covered} of {checked})");
        eprintln!("seed {seed}: {checked} pixels ({covered} under decals), worst abs error {worst:.5}");
    }
}
