//! GPU skinning (`render/src/skinning`) on lavapipe: a procedural two-joint cylinder bent by
//! 90° and swollen by a morph target renders as its CPU reference (the same geometry morphed and
//! linear-blend skinned on the CPU and drawn as a rigid mesh) in every pipeline, its shadow follows the pose with ray-traced shadows
//! on both ray-tracing tiers and with shadow maps, and a pose that stops changing stops costing.
//! A decal on the skin, placed at rest where the joints' weights blend, stays on its surface
//! point when the tube bends (every pipeline and decal method), while the same decal in the
//! world does not.
//!
//! Tolerance: mean absolute error ≤ 1e-4 and 99th percentile ≤ 1e-3 of the HDR target (weights
//! go to the GPU as 16-bit unorm, so positions may differ by ~1e-5 m; measured: mean ~1e-8,
//! p99 0). A shadow left in the bind pose (a BLAS not refit) costs several hundred pixels.

use engine::animation::{MorphWeights, Skin};
use engine::mesh::{MorphTarget, SkinWeights};
use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{RenderMirror, RenderSettings, RenderStats};
use render::{DecalMethod, PipelineKind, Tier};
use tests::{assert_no_validation_errors, error_stats, gpu_app_at, renderer};

const SIZE: (u32, u32) = (160, 120);

/// The settings of these tests: levels of detail off, because the CPU references are rigid
/// meshes with levels of their own and these tests check the pose, not the simplification
/// (`lod.rs` checks that levels of detail follow the skeleton).
fn full_detail() -> RenderSettings {
    RenderSettings { lod_pixels: 0.0, ..Default::default() }
}

/// A capped tube along +Y from 0 to 2 (radius 0.25) whose lower half follows joint 0 and upper
/// half joint 1, blended linearly over y ∈ [0.6, 1.4].
pub(crate) fn bendy_cylinder() -> Mesh {
    let (segments, rings) = (20u32, 16u32);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut indices = Vec::new();
    for r in 0..=rings {
        let y = 2.0 * r as f32 / rings as f32;
        for s in 0..=segments {
            let a = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push([0.25 * a.cos(), y, -0.25 * a.sin()]);
            normals.push([a.cos(), 0.0, -a.sin()]);
            uvs.push([s as f32 / segments as f32, 1.0 - y / 2.0]);
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (r * row + s, r * row + s + 1, (r + 1) * row + s + 1, (r + 1) * row + s);
            indices.extend_from_slice(&[a, b, c, a, c, d]);
        }
    }
    for (y, up) in [(0.0f32, false), (2.0, true)] {
        let center = positions.len() as u32;
        positions.push([0.0, y, 0.0]);
        normals.push([0.0, if up { 1.0 } else { -1.0 }, 0.0]);
        uvs.push([0.5, 0.5]);
        for s in 0..=segments {
            let a = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push([0.25 * a.cos(), y, -0.25 * a.sin()]);
            normals.push([0.0, if up { 1.0 } else { -1.0 }, 0.0]);
            uvs.push([0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin()]);
        }
        for s in 0..segments {
            let (p, q) = (center + 1 + s, center + 2 + s);
            if up { indices.extend_from_slice(&[center, p, q]) } else { indices.extend_from_slice(&[center, q, p]) }
        }
    }
    let weights: Vec<[f32; 4]> = positions
        .iter()
        .map(|p| {
            let t = ((p[1] - 0.6) / 0.8).clamp(0.0, 1.0);
            [1.0 - t, t, 0.0, 0.0]
        })
        .collect();
    // A morph target that swells the middle of the tube (up to 0.15 m outwards at the elbow).
    let bulge = positions.iter().map(|p| {
        let swell = 0.15 * (1.0 - (p[1] - 1.0).abs()).max(0.0);
        let out = Vec2::new(p[0], p[2]).normalize_or_zero() * swell;
        [out.x, 0.0, out.y]
    });
    let bulge = MorphTarget { positions: bulge.collect(), normals: Vec::new() };
    let mut mesh = Mesh::new(positions, normals, uvs, indices).expect("a valid tube");
    mesh.skin = Some(SkinWeights::normalized(vec![[0, 1, 0, 0]; weights.len()], weights));
    mesh.morph_targets = vec![bulge];
    mesh
}

/// The weight the tube's bulge is posed with.
const BULGE: f32 = 0.6;

/// The tube posed on the CPU by `matrices` (linear blend skinning, normals by the cofactor of
/// each vertex's blended matrix), as a rigid mesh.
fn posed_on_cpu(mesh: &Mesh, matrices: &[Mat4], morph_weights: &[f32]) -> Mesh {
    let skin = mesh.skin.as_ref().expect("skinned");
    let mut posed = mesh.clone();
    posed.skin = None;
    posed.morph_targets.clear();
    for i in 0..mesh.positions.len() {
        let (j, w) = (skin.joints[i], skin.weights[i]);
        // Morph targets first (their normal offsets are zero here), then the joints.
        let morphed = mesh
            .morph_targets
            .iter()
            .zip(morph_weights)
            .fold(Vec3::from(mesh.positions[i]), |p, (t, &m)| p + m * Vec3::from(t.positions[i]));
        posed.positions[i] = Skin::pose_point(matrices, morphed, j, w).into();
        let blend: Mat3 = (0..4).map(|k| Mat3::from_mat4(matrices[j[k] as usize]) * w[k]).fold(Mat3::ZERO, |a, b| a + b);
        let cofactor =
            Mat3::from_cols(blend.y_axis.cross(blend.z_axis), blend.z_axis.cross(blend.x_axis), blend.x_axis.cross(blend.y_axis));
        posed.normals[i] = (cofactor * Vec3::from(mesh.normals[i])).normalize().into();
        let t = mesh.tangents[i];
        let tangent = (blend * Vec3::new(t[0], t[1], t[2])).normalize();
        posed.tangents[i] = [tangent.x, tangent.y, tangent.z, t[3]];
    }
    posed
}

struct Bend {
    tube: Entity,
    elbow: Entity,
    mesh: Mesh,
    material: Handle<Material>,
}

/// The ground, a sun, a camera and the skinned tube on its two joints (the elbow at y = 1),
/// standing at x = -0.5 and bent by `angle` about Z.
fn scene(app: &mut App, angle: f32) -> Bend {
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.8));
    let red = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.8, 0.25, 0.1, 1.0), 0.0, 0.5));
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.9, -1.0, -0.5), Vec3::Z),
    ));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 2.4, 4.5).looking_at(Vec3::new(0.3, 0.6, 0.0), Vec3::Y)));
    let mesh = bendy_cylinder();
    let (tube, elbow) = spawn_tube(app, mesh.clone(), red, Vec3::new(-0.5, 0.0, 0.0), angle);
    app.world.entity_mut(tube).insert(MorphWeights(vec![BULGE]));
    Bend { tube, elbow, mesh, material: red }
}

/// Spawns `mesh` (the tube) skinned to two joints standing at `at`, the upper one (the elbow,
/// 1 m up) bent by `angle` about Z. Returns the tube and the elbow.
pub(crate) fn spawn_tube(app: &mut App, mesh: Mesh, material: Handle<Material>, at: Vec3, angle: f32) -> (Entity, Entity) {
    let root = app.world.spawn(Transform::from_translation(at)).id();
    let elbow = app.world.spawn((Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-angle)), ChildOf(root))).id();
    let handle = app.world.resource_mut::<Assets<Mesh>>().add(mesh);
    let skin = Skin { joints: vec![root, elbow], inverse_bind_matrices: vec![Mat4::IDENTITY, Mat4::from_translation(-Vec3::Y)].into() };
    (app.world.spawn((MeshInstance { mesh: handle, material }, skin, Transform::from_translation(at))).id(), elbow)
}

/// The joint matrices the tube is posed with now (what the CPU reference uses).
fn matrices(app: &mut App, bend: &Bend) -> Vec<Mat4> {
    let world = &app.world;
    let skin = world.get::<Skin>(bend.tube).unwrap();
    let mut out = Vec::new();
    skin.joint_matrices(world.get::<GlobalTransform>(bend.tube).unwrap(), |j| world.get::<GlobalTransform>(j).map(|g| g.0), &mut out);
    out
}

fn frames(app: &mut App, n: usize) -> Hdr {
    for _ in 0..n {
        app.update();
    }
    renderer(app).read_hdr().expect("read back the HDR target")
}

/// Renders the bent tube skinned on the GPU, then the same scene with its CPU-posed copy as a
/// rigid mesh; returns both images and the bind-pose image.
type Hdr = Vec<[f32; 4]>;

fn skinned_and_reference(pipeline: PipelineKind, tier: Tier, shadow_maps: bool) -> (Hdr, Hdr, Hdr) {
    let mut settings = RenderSettings { pipeline, ..full_detail() };
    settings.lights.shadow_maps = shadow_maps;
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
    assert_eq!(renderer(&mut app).tier(), tier, "lavapipe offers every tier");
    let bend = scene(&mut app, 0.0);
    let rest = frames(&mut app, 3);
    app.world
        .entity_mut(bend.elbow)
        .insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2)));
    let skinned = frames(&mut app, 3);
    assert_no_validation_errors(&mut app);
    let stats = app.world.resource::<RenderStats>().last;
    assert_eq!(stats.skinned_meshes, 0, "a pose that stopped changing is not skinned again");

    // The reference: the CPU-posed tube as a rigid mesh where the skinned one was.
    let posed = posed_on_cpu(&bend.mesh, &matrices(&mut app, &bend), &[BULGE]);
    let handle = app.world.resource_mut::<Assets<Mesh>>().add(posed);
    app.world.entity_mut(bend.tube).remove::<Skin>().insert(MeshInstance { mesh: handle, material: bend.material });
    let reference = frames(&mut app, 3);
    assert_no_validation_errors(&mut app);
    (skinned, reference, rest)
}

fn assert_matches(pipeline: PipelineKind, tier: Tier, shadow_maps: bool) {
    let (skinned, reference, rest) = skinned_and_reference(pipeline, tier, shadow_maps);
    let what = format!("{pipeline:?} on {tier:?}{}", if shadow_maps { " with shadow maps" } else { "" });
    let (mean, p99) = error_stats(&skinned, &reference, |_| true);
    assert!(mean <= 1e-4 && p99 <= 1e-3, "{what}: the skinned tube differs from its CPU reference (mean {mean}, p99 {p99})");
    let (moved, _) = error_stats(&rest, &reference, |_| true);
    assert!(moved > 20.0 * mean.max(1e-4), "{what}: bending must change the image ({moved} vs {mean})");
}

#[test]
fn the_bent_tube_matches_its_cpu_reference_in_every_pipeline_with_ray_traced_shadows() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        assert_matches(pipeline, Tier::RayQuery, false);
    }
}

#[test]
fn its_shadow_follows_the_pose_on_the_ray_tracing_pipeline_tier_and_with_shadow_maps() {
    assert_matches(PipelineKind::Deferred, Tier::RayTracingPipeline, false);
    assert_matches(PipelineKind::ForwardPlus, Tier::NoRayTracing, true);
}

#[test]
fn only_changed_poses_are_skinned_and_refit() {
    let mut app = gpu_app_at(SIZE.0, SIZE.1, full_detail(), Tier::RayQuery);
    let bend = scene(&mut app, 0.3);
    app.update();
    let first = app.world.resource::<RenderStats>().last;
    assert_eq!(first.skinned_meshes, 1, "a new posed mesh is skinned in its first frame");
    assert_eq!(first.skinned_vertices, bend.mesh.positions.len() as u64);
    // Its copy in the mesh pool: its vertices, then (16-byte aligned) a previous position (16
    // bytes) each.
    let n = bend.mesh.positions.len() as u32;
    let copy = render::scene::vertex::previous_positions_offset(n) + n as u64 * 16;
    assert_eq!(first.posed_mesh_bytes, copy, "the memory report counts the posed copy");
    app.update(); // settles: its previous positions catch up
    assert_eq!(app.world.resource::<RenderStats>().last.skinned_meshes, 1);
    for _ in 0..2 {
        app.update();
        let c = app.world.resource::<RenderStats>().last;
        assert_eq!((c.skinned_meshes, c.scene_blas_refits, c.bytes_uploaded), (0, 0, 0), "a still pose costs nothing");
    }
    for i in 0..3 {
        let angle = 0.4 + 0.1 * i as f32;
        app.world.entity_mut(bend.elbow).insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-angle)));
        app.update();
        let c = app.world.resource::<RenderStats>().last;
        assert_eq!(c.skinned_meshes, 1, "a moved joint poses its mesh");
        assert_eq!(c.scene_blas_refits + c.scene_blas_builds, 1, "and refits (or rebuilds) its BLAS");
    }
    app.world.despawn(bend.tube);
    app.update();
    app.update();
    assert_no_validation_errors(&mut app);
}

/// With nothing tracing the scene (ray-traced shadows off; ambient occlusion and reflections are
/// off in the test apps) a moving skin refits nothing and no TLAS is built or updated; the frame
/// shadows come back on, the structures catch up (the skin's BLAS, built while shadows were on
/// at first, is refit to the pose it has now) and the shadow shows the current pose, as in an app
/// whose shadows were never off. On both ray-tracing tiers.
#[test]
fn without_a_ray_traced_consumer_nothing_is_refit_and_the_shadow_catches_up_when_one_comes_back() {
    for tier in [Tier::RayQuery, Tier::RayTracingPipeline] {
        // `pause`: shadows on in the first frame, off in the next three, on again in the last.
        let render = |pause: bool| {
            let settings = RenderSettings { pipeline: PipelineKind::Deferred, ..full_detail() };
            let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
            let bend = scene(&mut app, 0.3);
            for i in 0..4 {
                app.world.resource_mut::<RenderSettings>().lights.shadows = !pause || i == 0;
                let angle = 0.3 + 0.25 * i as f32;
                app.world.entity_mut(bend.elbow).insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-angle)));
                app.update();
                let c = app.world.resource::<RenderStats>().last;
                assert_eq!(c.skinned_meshes, 1, "{tier:?}: the skin is posed every frame it moves");
                if pause && i > 0 {
                    let work = (c.scene_blas_builds, c.scene_blas_refits, c.scene_tlas_builds, c.scene_tlas_updates);
                    assert_eq!(work, (0, 0, 0, 0), "{tier:?}, frame {i}: nothing traces the scene, so nothing is built or refit");
                }
            }
            app.world.resource_mut::<RenderSettings>().lights.shadows = true;
            let hdr = frames(&mut app, 1);
            assert_no_validation_errors(&mut app);
            (hdr, app.world.resource::<RenderStats>().last)
        };
        let (caught_up, c) = render(true);
        let work = (c.scene_blas_builds + c.scene_blas_refits, c.scene_tlas_builds);
        assert_eq!(work, (1, 1), "{tier:?}: the skin's BLAS is refit (or rebuilt) and the TLAS built the frame shadows return");
        let (always, _) = render(false);
        let (mean, p99) = error_stats(&caught_up, &always, |_| true);
        assert!(mean <= 1e-4 && p99 <= 1e-3, "{tier:?}: the caught-up shadow differs from the always-traced one (mean {mean}, p99 {p99})");
    }
}

/// A character smaller on screen than `refit_pixels` has its refits deferred: while its pose
/// changes every frame, its structure is refit at least once every `MAX_REFIT_STALENESS + 1`
/// frames and never lags more than `MAX_REFIT_STALENESS` frames (the counters say so); once the
/// pose holds, the structure catches up within that bound, and the shadow is the one an app that
/// refits every frame shows.
#[test]
fn deferred_refits_lag_at_most_their_bound_and_catch_up_when_the_pose_holds() {
    let bound = render::accel::MAX_REFIT_STALENESS;
    let render = |refit_pixels: f32| {
        let settings = RenderSettings { pipeline: PipelineKind::Deferred, refit_pixels, ..full_detail() };
        let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, Tier::RayQuery);
        let bend = scene(&mut app, 0.3);
        app.update(); // the first pose: the structure is built
        let (mut refits, mut deferred, mut behind) = (0, 0, 0);
        for i in 1..=12 {
            let angle = 0.3 + 0.05 * i as f32;
            app.world.entity_mut(bend.elbow).insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-angle)));
            app.update();
            let c = app.world.resource::<RenderStats>().last;
            assert_eq!(c.scene_blas_refits + c.scene_blas_refits_deferred, 1, "frame {i}: the moving skin is refit or waits");
            assert!(
                c.scene_blas_stalest <= u64::from(bound),
                "frame {i}: {} frames behind, beyond the bound {bound}",
                c.scene_blas_stalest
            );
            behind = if c.scene_blas_refits_deferred > 0 { behind + 1 } else { 0 };
            assert!(behind <= bound, "frame {i}: deferred {behind} frames in a row");
            (refits, deferred) = (refits + c.scene_blas_refits, deferred + c.scene_blas_refits_deferred);
        }
        // The pose holds: within the bound every deferred refit is done.
        let mut waiting = u64::MAX;
        for _ in 0..=bound {
            app.update();
            waiting = app.world.resource::<RenderStats>().last.scene_blas_refits_deferred;
        }
        assert_eq!(waiting, 0, "refit_pixels {refit_pixels}: the structure caught up within {bound} frames of the pose holding");
        let hdr = frames(&mut app, 1);
        assert_no_validation_errors(&mut app);
        (hdr, refits, deferred)
    };
    // Every character is "small" under a limit taller than the image.
    let (caught_up, refits, deferred) = render(10_000.0);
    assert!(deferred > 0 && refits >= 12 / u64::from(bound + 1), "deferred {deferred}, refit {refits} of 12 moving frames");
    let (always, refits_always, deferred_always) = render(0.0);
    assert_eq!((refits_always, deferred_always), (12, 0), "refit_pixels 0 refits every frame the pose changes");
    let (mean, p99) = error_stats(&caught_up, &always, |_| true);
    assert!(mean <= 1e-4 && p99 <= 1e-3, "the caught-up shadow differs from the always-refit one (mean {mean}, p99 {p99})");
}

/// The centroid (pixels) and count of the pixels where `pick` holds.
fn centroid(hdr: &[[f32; 4]], width: u32, pick: impl Fn([f32; 4]) -> bool) -> (Vec2, usize) {
    let mut sum = Vec2::ZERO;
    let mut n = 0;
    for (i, p) in hdr.iter().enumerate() {
        if pick(*p) {
            sum += Vec2::new((i as u32 % width) as f32 + 0.5, (i as u32 / width) as f32 + 0.5);
            n += 1;
        }
    }
    (sum / n.max(1) as f32, n)
}

#[test]
fn a_decal_on_the_skin_stays_on_its_surface_point_with_every_method() {
    const BIG: (u32, u32) = (320, 240);
    // Each decal method once and each way of reading the surface once, as the decal tests'
    // `COVER` (how a method finds a decal on a skin does not depend on the pipeline; how each
    // pipeline's surface meets each method is held to the CPU reference in `decals`).
    let configs = [
        (Tier::RayQuery, PipelineKind::Forward, DecalMethod::RayQuery),
        (Tier::RayTracingPipeline, PipelineKind::VisBuffer, DecalMethod::RayPipeline),
        (Tier::NoRayTracing, PipelineKind::Forward, DecalMethod::Clustered),
        (Tier::NoRayTracing, PipelineKind::Deferred, DecalMethod::Clustered),
        // Forward+ here walks the clustered lists in its shading pass (decals_in_forward_shading).
        (Tier::NoRayTracing, PipelineKind::ForwardPlus, DecalMethod::Clustered),
    ];
    for (tier, pipeline, method) in configs {
        let in_shading = pipeline == PipelineKind::ForwardPlus;
        let what = format!("{pipeline:?} with {method:?} decals on {tier:?} (in the shading: {in_shading})");
        let settings = RenderSettings { pipeline, decal_method: method, decals_in_forward_shading: in_shading, ..full_detail() };
        let mut app = gpu_app_at(BIG.0, BIG.1, settings, tier);
        let bend = scene(&mut app, 0.0);
        // A green decal on the skin, placed at rest on the tube's front where the weights blend
        // (y = 1.3: 1/8 joint 0, 7/8 joint 1); later the same decal in the world.
        let rest = Vec3::new(0.0, 1.3, 0.25);
        let place = Transform::from_translation(rest).with_scale(Vec3::new(0.2, 0.2, 0.3));
        let material = app
            .world
            .resource_mut::<Assets<DecalMaterial>>()
            .add(DecalMaterial { base_color: Some(Vec4::new(0.05, 0.9, 0.05, 1.0)), ..Default::default() });
        let decal = Decal { angle_fade: None, ..Decal::new(material) };
        let on_skin = app.world.spawn((decal.clone().on_skin(), place, ChildOf(bend.tube))).id();
        let green = |p: [f32; 4]| p[1] > 1.5 * p[0] && p[1] > 1.5 * p[2];
        let pixel_of = |app: &mut App, bend: &Bend| {
            let m = matrices(app, bend);
            // The surface point there: swollen by the bulge (along +z on the front), then posed.
            let swollen = rest + Vec3::Z * 0.15 * (1.0 - (rest.y - 1.0).abs()) * BULGE;
            let posed = Skin::pose_point(&m, swollen, [0, 1, 0, 0], [0.125, 0.875, 0.0, 0.0]);
            let world = app.world.get::<GlobalTransform>(bend.tube).unwrap().compute_matrix().transform_point3(posed);
            let clip = app.world.resource::<RenderMirror>().0.camera().view_proj * world.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            Vec2::new((ndc.x + 1.0) * 0.5 * BIG.0 as f32, (1.0 - ndc.y) * 0.5 * BIG.1 as f32)
        };
        let (at_rest, at_rest_n) = centroid(&frames(&mut app, 3), BIG.0, green);
        let expected_rest = pixel_of(&mut app, &bend);
        assert!(at_rest_n > 20, "{what}: the decal on the skin shows ({at_rest_n} pixels)");
        assert!(at_rest.distance(expected_rest) < 1.5, "{what}: at rest it is where it was placed ({at_rest} vs {expected_rest})");

        app.world
            .entity_mut(bend.elbow)
            .insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-std::f32::consts::FRAC_PI_2)));
        let (bent, bent_n) = centroid(&frames(&mut app, 3), BIG.0, green);
        let expected = pixel_of(&mut app, &bend);
        assert!(expected.distance(expected_rest) > 8.0, "{what}: the bend moves the point");
        assert!(bent_n * 2 > at_rest_n, "{what}: the decal on the skin keeps its size ({bent_n} of {at_rest_n} pixels)");
        assert!(bent.distance(expected) < 1.5, "{what}: the decal on the skin follows its surface point ({bent} vs {expected})");

        // The same decal in the world stays where it was placed, and the skin slides away under it.
        app.world.despawn(on_skin);
        app.world.spawn((decal, place, ChildOf(bend.tube)));
        let (world, world_n) = centroid(&frames(&mut app, 3), BIG.0, green);
        assert_no_validation_errors(&mut app);
        assert!(
            world_n * 2 < bent_n || world.distance(expected) > 4.0,
            "{what}: a world decal does not follow the skin ({world_n} pixels at {world})"
        );
    }
}

#[test]
fn a_morph_target_without_a_skin_follows_its_weight() {
    let mut app = gpu_app_at(SIZE.0, SIZE.1, RenderSettings { pipeline: PipelineKind::VisBuffer, ..full_detail() }, Tier::RayQuery);
    let bend = scene(&mut app, 0.0);
    app.world.despawn(bend.tube);
    // A 1 m sphere whose target pushes its top half 0.4 m up, at weight 0.75.
    let mut ball = shapes::uv_sphere(0.5, 24, 12);
    let lift: Vec<[f32; 3]> = ball.positions.iter().map(|p| if p[1] > 0.0 { [0.0, 0.4, 0.0] } else { [0.0; 3] }).collect();
    ball.morph_targets = vec![MorphTarget { positions: lift.clone(), normals: Vec::new() }];
    let mut reference = ball.clone();
    reference.morph_targets.clear();
    for (p, d) in reference.positions.iter_mut().zip(&lift) {
        p[1] += 0.75 * d[1];
    }
    let at = Transform::from_xyz(0.3, 0.6, 0.0);
    let handle = app.world.resource_mut::<Assets<Mesh>>().add(ball);
    let ball = app.world.spawn((MeshInstance { mesh: handle, material: bend.material }, at, MorphWeights(vec![0.75]))).id();
    let morphed = frames(&mut app, 3);
    assert_eq!(app.world.resource::<RenderStats>().last.skinned_meshes, 0, "posed once, then still");
    let handle = app.world.resource_mut::<Assets<Mesh>>().add(reference);
    app.world.entity_mut(ball).insert(MeshInstance { mesh: handle, material: bend.material });
    let expected = frames(&mut app, 3);
    assert_no_validation_errors(&mut app);
    let (mean, p99) = error_stats(&morphed, &expected, |_| true);
    assert!(mean <= 1e-4 && p99 <= 1e-3, "the morphed sphere differs from its CPU reference (mean {mean}, p99 {p99})");
}

/// Motion vectors of a skinned mesh (`render/src/motion`): the tube bends further in one frame;
/// where its upper half (joint 1 alone) shows, the motion is the CPU's projection of the point
/// now and turned back about the elbow; its lower half (joint 0, still) has none. The skinning
/// pass's previous positions give the motion, so this holds within a thirtieth of a pixel: found
/// per pixel from the ids the deferred and visibility-buffer pipelines keep, and the forward
/// prepass's when it writes them for the reflection rays, or because many posed vertices were
/// skinned (49 copies of the tube); drawn again as a mover in a forward frame whose prepass keeps
/// no ids (no reflections, no decal pass, one tube).
#[test]
fn a_bending_skin_has_the_motion_of_its_joints_in_every_pipeline() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        skin_motion(pipeline, true, 0);
    }
    skin_motion(PipelineKind::Forward, false, 0);
    // 48 more copies on the same joints: 49 × 401 vertices skinned, three times the image's
    // pixels, so the forward prepass keeps ids rather than draw them all again as movers.
    skin_motion(PipelineKind::Forward, false, 48);
}

/// `copies`: more instances of the tube on the same joints, in the same place.
fn skin_motion(pipeline: PipelineKind, reflections: bool, copies: usize) {
    let reflections = if reflections { render::ReflectionSettings::default() } else { render::ReflectionSettings::OFF };
    let settings =
        RenderSettings { pipeline, aa: render::AntiAliasing::Taa, reflections, decal_method: render::DecalMethod::Off, ..full_detail() };
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, Tier::RayQuery);
    let (a0, a1) = (0.3f32, 0.6f32);
    let bend = scene(&mut app, a0);
    let copy = {
        let tube = app.world.entity(bend.tube);
        (tube.get::<MeshInstance>().cloned(), tube.get::<Skin>().cloned(), *tube.get::<Transform>().unwrap(), MorphWeights(vec![BULGE]))
    };
    for _ in 0..copies {
        let (instance, skin, transform, weights) = copy.clone();
        app.world.spawn((instance.unwrap(), skin.unwrap(), transform, weights));
    }
    for _ in 0..3 {
        app.update();
    }
    app.world.entity_mut(bend.elbow).insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-a1)));
    app.update();
    assert_no_validation_errors(&mut app);
    assert_eq!(app.world.resource::<RenderStats>().last.skinned_meshes, 1 + copies as u64);
    let movers = u64::from(pipeline == PipelineKind::Forward && reflections.mode == render::ReflectionMode::Off && copies == 0);
    assert_eq!(
        app.world.resource::<RenderStats>().last.motion_movers,
        movers,
        "{pipeline:?}: the posed tube is a mover only where no ids are kept"
    );
    let motion = renderer(&mut app).read_motion().expect("read back the motion vectors");
    let depth = renderer(&mut app).read_depth().expect("read back depth");
    let camera = app.world.resource::<RenderMirror>().0.gpu_camera();
    let elbow = Vec3::new(-0.5, 1.0, 0.0);
    let project = |p: Vec3| {
        let c = camera.motion_view_proj * p.extend(1.0);
        Vec2::new(c.x, c.y) / c.w
    };
    let (mut upper, mut lower) = ((0usize, 0.0f32), (0usize, 0.0f32));
    for y in 0..SIZE.1 {
        for x in 0..SIZE.0 {
            let i = (y * SIZE.0 + x) as usize;
            let ndc = (Vec2::new((x as f32 + 0.5) / SIZE.0 as f32, (y as f32 + 0.5) / SIZE.1 as f32) * 2.0 - 1.0) * Vec2::new(1.0, -1.0);
            let p = camera.inv_view_proj * Vec4::new(ndc.x, ndc.y, depth[i], 1.0);
            let p = p.truncate() / p.w;
            // The point in the unbent tube's frame about the elbow (upper half: q.y > 0).
            let q = Quat::from_rotation_z(a1) * (p - elbow);
            let radius = Vec2::new(q.x, q.z).length();
            let got = Vec2::new(motion[i][0], motion[i][1]);
            if depth[i] > 0.0 && p.y > 0.05 && q.y > 0.45 && q.y < 0.95 && radius < 0.45 {
                let before = elbow + Quat::from_rotation_z(a1 - a0) * (p - elbow);
                let expected = (project(p) - project(before)) * Vec2::new(0.5, -0.5);
                upper = (upper.0 + 1, upper.1.max((got - expected).abs().max_element()));
            } else if depth[i] > 0.0 && p.y > 0.05 && p.y < 0.5 && (p - Vec3::new(-0.5, p.y, 0.0)).length() < 0.45 {
                lower = (lower.0 + 1, lower.1.max(got.abs().max_element()));
            }
        }
    }
    eprintln!(
        "{pipeline:?}: skinned motion: upper half {} pixels, worst error {:.2e} UV; lower half {} pixels, worst {:.2e}",
        upper.0, upper.1, lower.0, lower.1
    );
    assert!(upper.0 > 50 && lower.0 > 50, "{pipeline:?}: both halves show: {upper:?} {lower:?}");
    // Measured 2.3e-4: motions of up to 0.1 UV rounded to RGBA16F, and silhouette pixels.
    assert!(upper.1 <= 5e-4, "{pipeline:?}: the upper half moves with its joint: worst error {} UV", upper.1);
    assert!(lower.1 <= 2e-4, "{pipeline:?}: the lower half stays: worst motion {} UV", lower.1);
}

/// Pipelined rendering (`RenderSettings::pipelined`: upload, recording and submission on the
/// render thread while the next update runs) draws the frames in-place rendering draws: a tube
/// bending further every frame gives the same image and the same work counters, frame by frame,
/// filed one update later; between updates the renderer is on the render thread, and
/// `finish_frames` takes it back.
#[test]
fn pipelined_rendering_draws_the_same_frames_one_update_later() {
    let run = |pipelined: bool| {
        let mut app = gpu_app_at(SIZE.0, SIZE.1, RenderSettings { pipelined, ..full_detail() }, Tier::RayQuery);
        let bend = scene(&mut app, 0.0);
        for i in 0..6u64 {
            let angle = 0.25 * i as f32;
            app.world.entity_mut(bend.elbow).insert(Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(Quat::from_rotation_z(-angle)));
            app.update();
            let latest = app.world.resource::<RenderStats>().latest().map(|s| (s.frame, s.pipelined));
            let expected = if pipelined { i.checked_sub(1).map(|f| (f, true)) } else { Some((i, false)) };
            assert_eq!(latest, expected, "pipelined {pipelined}: the frame filed after update {i}");
            let counters = app.world.resource::<RenderStats>().last;
            assert_eq!(counters.instances > 0, latest.is_some(), "pipelined {pipelined}: the filed frame's counters after update {i}");
            assert_eq!(app.world.contains_resource::<plugins::GpuRenderer>(), !pipelined, "between updates, pipelined {pipelined}");
        }
        plugins::finish_frames(&mut app.world);
        assert_no_validation_errors(&mut app);
        let frames: Vec<_> = app
            .world
            .resource::<RenderStats>()
            .completed
            .iter()
            .map(|s| (s.frame, s.counters.skinned_meshes, s.counters.bytes_uploaded))
            .collect();
        assert!(app.world.resource::<RenderStats>().completed.iter().all(|s| s.pipelined == pipelined && s.cpu_frame_ms > 0.0));
        (renderer(&mut app).read_hdr().expect("read back the HDR target"), frames)
    };
    let (in_place, in_place_frames) = run(false);
    let (pipelined, pipelined_frames) = run(true);
    assert_eq!(in_place_frames.len(), 6, "every frame finished: {in_place_frames:?}");
    assert!(in_place_frames.iter().all(|&(_, skinned, _)| skinned == 1), "the tube is skinned every frame: {in_place_frames:?}");
    assert_eq!(pipelined_frames, in_place_frames, "the same work, frame by frame");
    let (mean, max) = error_stats(&pipelined, &in_place, |_| true);
    assert!(mean <= 1e-6 && max <= 1e-5, "pipelined and in place differ (mean {mean}, p99 {max})");
}

/// A crowd that the animation budget poses every fourth frame (a quarter of it each frame,
/// staggered) refits another set of structures each frame, so each frame slot's commands come
/// round every other frame of the slot; the slot keeps more than one recorded command buffer, so
/// once the cycle has been recorded, frames that refit submit a recorded buffer again. Eight
/// foxes 60 m away (2 px), ray-traced shadows (the refits' reader), under validation.
#[test]
fn a_crowd_posed_every_fourth_frame_submits_its_recorded_refits_again() {
    use engine::animation::{AnimationBudget, AnimationPlayer, AnimationStats};
    use engine::camera::Camera;
    use engine::gltf::GltfAnimations;

    let mut app = gpu_app_at(SIZE.0, SIZE.1, full_detail(), Tier::RayQuery);
    app.world.resource_mut::<AnimationBudget>().enabled = true;
    let mut fox = engine::gltf::load(&tests::shared_gltf_dir().join("Fox/Fox.glb")).expect("the Fox loads");
    fox.images.clear();
    let prefab = fox.into_prefab(&mut app.world);
    for i in 0..8 {
        let root = prefab.spawn(&mut app.world);
        let run = app.world.get::<GltfAnimations>(root).unwrap().0[2];
        let at = Transform::from_xyz(i as f32 * 2.0 - 7.0, 0.0, -60.0).with_scale(Vec3::splat(0.01));
        app.world.entity_mut(root).insert((AnimationPlayer::new(run), at));
    }
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 0.0)));
    app.world.spawn((engine::light::DirectionalLight::default(), Transform::default().looking_at(Vec3::new(0.3, -1.0, -0.4), Vec3::Z)));
    let mut reused_refits = 0;
    for frame in 0..28 {
        app.update();
        let animation = *app.world.resource::<AnimationStats>();
        let c = app.world.resource::<RenderStats>().last;
        if frame >= 2 {
            assert_eq!(animation.max_period, 4, "frame {frame}: the foxes are a few pixels");
            assert!(animation.sampled < 8, "frame {frame}: {} of 8 foxes sampled", animation.sampled);
        }
        if frame >= 12 && c.commands_reused && c.scene_blas_refits > 0 {
            reused_refits += 1;
        }
    }
    assert!(reused_refits >= 4, "of the last 16 frames, {reused_refits} submitted their refits again as recorded");
    assert_no_validation_errors(&mut app);
}

/// A walking crowd's characters cross `refit_pixels` a few at a time; their class (refit every
/// frame, or on their slot's turn) is decided once an epoch of `REFIT_CLASS_FRAMES` frames, so
/// that each slot's refits, and its command buffer, repeat between crossings. Here the camera
/// walks along a column of twenty running foxes (1 m tall, 0.4 m apart, at 0.4 m a frame), so
/// that one comes within the limit every frame from the 17th frame on: the structures still lag
/// at most `MAX_REFIT_STALENESS` frames behind every pose, the foxes ahead go on to be refit
/// every frame, most frames submit their commands again as recorded (measured: 33 of the 36
/// frames; deciding the classes every frame, 18), and those that do not come at the start of
/// an epoch, two frames at most in a row (one per slot; listing the refits in the order the
/// meshes began to wait, measured: three).
#[test]
fn a_crowd_crossing_the_refit_limit_keeps_its_recorded_refits_within_an_epoch() {
    use engine::animation::AnimationPlayer;
    use engine::camera::Camera;
    use engine::gltf::GltfAnimations;

    const FOXES: u64 = 20;
    let bound = u64::from(render::accel::MAX_REFIT_STALENESS);
    // A fox (a sphere of 0.9 m around its bounds) is 12 px tall 15 m away in a 120-pixel image.
    let settings = RenderSettings { refit_pixels: 12.0, ..full_detail() };
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, Tier::RayQuery);
    let mut fox = engine::gltf::load(&tests::shared_gltf_dir().join("Fox/Fox.glb")).expect("the Fox loads");
    fox.images.clear();
    let prefab = fox.into_prefab(&mut app.world);
    for i in 0..FOXES {
        let root = prefab.spawn(&mut app.world);
        let run = app.world.get::<GltfAnimations>(root).unwrap().0[2];
        let side = if i % 2 == 0 { -1.0 } else { 1.0 };
        let at = Transform::from_xyz(side, 0.0, -12.0 - 0.4 * i as f32).with_scale(Vec3::splat(0.01));
        app.world.entity_mut(root).insert((AnimationPlayer::new(run), at));
    }
    let camera = app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 10.0))).id();
    app.world.spawn((engine::light::DirectionalLight::default(), Transform::default().looking_at(Vec3::new(0.3, -1.0, -0.4), Vec3::Z)));
    let (mut reused, mut missed_in_a_row, mut deferred_at_start, mut deferred_later) = (0, 0, 0, 0);
    for frame in 0..40 {
        app.world.entity_mut(camera).insert(Transform::from_xyz(0.0, 1.0, 10.0 - 0.4 * frame as f32));
        app.update();
        let c = app.world.resource::<RenderStats>().last;
        if frame == 0 {
            continue; // the structures' first build
        }
        assert_eq!(c.scene_blas_refits + c.scene_blas_refits_deferred, FOXES, "frame {frame}: every running fox is refit or waits");
        assert!(c.scene_blas_stalest <= bound, "frame {frame}: {} frames behind, beyond the bound {bound}", c.scene_blas_stalest);
        match frame {
            2 => deferred_at_start = c.scene_blas_refits_deferred,
            38 => deferred_later = c.scene_blas_refits_deferred,
            _ => {}
        }
        if frame >= 4 {
            reused += u32::from(c.commands_reused);
            missed_in_a_row = if c.commands_reused { 0 } else { missed_in_a_row + 1 };
            assert!(missed_in_a_row <= 2, "frame {frame}: {missed_in_a_row} frames in a row recorded their commands anew");
        }
    }
    // Frames 2 and 38 are of the same slot: the same foxes' turn.
    assert!(
        deferred_later < deferred_at_start,
        "the foxes ahead went on to be refit every frame (deferred {deferred_at_start}, then {deferred_later})"
    );
    assert!(reused >= 28, "of the last 36 frames, {reused} submitted their commands again as recorded");
    assert_no_validation_errors(&mut app);
}
