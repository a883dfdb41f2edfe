//! Levels of detail (`render/src/lod`) on lavapipe, one renderer for every case: at the distance
//! a coarser level is chosen, a sphere's silhouette stays within the limit's pixels (and one
//! more for rasterisation) of its full-detail silhouette, at two limits, while fewer triangles
//! are drawn; a skinned tube bent by 90° follows its skeleton at its coarser levels, within
//! three pixels more than that (its levels are simplified in the rest pose: the bend shows more
//! than the rest pose's error; a level left in the rest pose would miss the bent half by about
//! twenty pixels); the visibility
//! buffer rebuilds a coarser level's triangles (its normals equal forward's, which interpolates
//! them), and the level-of-detail view colours a surface by the level drawn in every pipeline; and an instance between the two limits of the hysteresis band keeps the level it
//! came with, as the rules of `shaders/cull.comp`, replayed on the CPU, say. A far skinned tube
//! whose pose changes every frame skins its level's vertices alone and draws bit for bit what it
//! draws fully skinned; a glTF file's own levels (`MSFT_lod`) are drawn far away.

use engine::prelude::*;
use plugins::{RenderSettings, RenderStats};
use render::lod::{LOD_HYSTERESIS, MeshLods};
use render::{CullingStats, DebugView, PipelineKind};
use tests::{assert_no_validation_errors, error_stats, gpu_app, renderer};

const SIZE: (u32, u32) = (128, 128);

/// The sphere's resolution: 4,096 triangles.
fn sphere() -> Mesh {
    shapes::uv_sphere(1.0, 64, 32)
}

/// Renders four frames (statistics come back two frames late) and returns the culling
/// statistics and the depth.
fn settle(app: &mut App) -> (CullingStats, Vec<f32>) {
    for _ in 0..4 {
        app.update();
    }
    let stats = app.world.resource::<RenderStats>().last.culling;
    (stats, renderer(app).read_depth().expect("read back the depth"))
}

fn set_lod(app: &mut App, pixels: f32) {
    app.world.resource_mut::<RenderSettings>().lod_pixels = pixels;
}

/// Pixels of `columns` whose coverage differs between `a` and `b` (depth > 0: covered, reverse
/// Z) and that have no pixel of `b` within `reach` pixels (Chebyshev) covered as they are in
/// `a`: what strays further than `reach` from `b`'s silhouette.
fn strays(a: &[f32], b: &[f32], columns: std::ops::Range<i32>, reach: i32) -> usize {
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    let covered = |d: &[f32], x: i32, y: i32| d[(y * w + x) as usize] > 0.0;
    let mut count = 0;
    for y in 0..h {
        for x in columns.clone() {
            let want = covered(a, x, y);
            if want == covered(b, x, y) {
                continue;
            }
            let near = (-reach..=reach).any(|dy| {
                (-reach..=reach).any(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    u >= 0 && v >= 0 && u < w && v < h && covered(b, u, v) == want
                })
            });
            count += usize::from(!near);
        }
    }
    count
}

#[test]
fn coarser_levels_keep_the_silhouette_within_their_limit_and_follow_the_skeleton() {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { pipeline: PipelineKind::Forward, ..Default::default() });
    let red = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.8, 0.2, 0.1, 1.0), 0.0, 0.5));
    let sphere = app.world.resource_mut::<Assets<Mesh>>().add(sphere());
    app.world.spawn((MeshInstance { mesh: sphere, material: red }, Transform::from_xyz(-1.2, 0.6, -6.0)));
    // The tube without its morph target (a mesh with morph targets has no levels), bent by 90°.
    let mut tube = crate::skinning::bendy_cylinder();
    tube.morph_targets.clear();
    crate::skinning::spawn_tube(&mut app, tube, red, Vec3::new(0.6, -1.4, -6.0), std::f32::consts::FRAC_PI_2);
    app.world.spawn((DirectionalLight { illuminance: 3.0, ..Default::default() }, Transform::default().looking_at(-Vec3::Y, Vec3::Z)));
    app.world.spawn((Camera::default(), Transform::default()));

    set_lod(&mut app, 0.0);
    let (full, full_depth) = settle(&mut app);
    assert_eq!(full.lod_instances[0], 2, "levels of detail off: both drawn in full: {full:?}");
    for limit in [1.0f32, 4.0] {
        set_lod(&mut app, limit);
        let (lod, depth) = settle(&mut app);
        assert_eq!(lod.lod_instances.iter().sum::<u64>(), 2, "{limit} px: both drawn: {lod:?}");
        assert!(lod.lod_instances[0] < 2, "{limit} px: a coarser level is chosen at 6 m: {lod:?}");
        assert!(lod.triangles < full.triangles, "{limit} px: fewer triangles ({} of {})", lod.triangles, full.triangles);
        let both = |columns: std::ops::Range<i32>, reach: i32| {
            strays(&depth, &full_depth, columns.clone(), reach) + strays(&full_depth, &depth, columns, reach)
        };
        let reach = limit.ceil() as i32 + 1;
        assert_eq!(both(0..64, reach), 0, "{limit} px: sphere pixels further than {reach} px from the full silhouette");
        // The skinned tube's levels are simplified in its rest pose: bent by 90° its elbow
        // shows more than the rest pose's error (measured: 4 px at both limits), where a level
        // left in the rest pose would miss the bent half (1 m, about 20 px here) entirely.
        let bent = reach + 3;
        assert_eq!(both(64..128, bent), 0, "{limit} px: tube pixels further than {bent} px from the full silhouette");
        assert!(both(64..128, 0) > 0, "{limit} px: the tube is drawn at a coarser level");
    }
    // A level drawn in the rest pose would stand straight: the bent half's pixels would differ
    // by far more than the limit.
    let covered = full_depth.iter().filter(|&&d| d > 0.0).count();
    assert!(covered > 400, "the two are on screen ({covered} pixels)");
    assert_no_validation_errors(&mut app);
}

#[test]
fn the_visibility_buffer_rebuilds_a_coarser_levels_triangles_and_the_level_view_colours_them_in_every_pipeline() {
    let settings = RenderSettings { debug_view: DebugView::Normal, lod_pixels: 8.0, ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    let white = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::ONE, 0.0, 0.5));
    let sphere = app.world.resource_mut::<Assets<Mesh>>().add(sphere());
    app.world.spawn((MeshInstance { mesh: sphere, material: white }, Transform::from_xyz(0.0, 0.0, -5.0)));
    app.world.spawn((Camera::default(), Transform::default()));
    let mut images = Vec::new();
    for pipeline in [PipelineKind::Forward, PipelineKind::VisBuffer] {
        app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
        let (stats, _) = settle(&mut app);
        assert_eq!(stats.lod_instances[0], 0, "{pipeline:?}: a coarser level at 8 px: {stats:?}");
        images.push(renderer(&mut app).read_hdr().expect("read back the HDR target"));
    }
    // A wrong triangle number would rebuild another triangle's normals: errors of order 1.
    let (mean, p99) = error_stats(&images[0], &images[1], |_| true);
    assert!(mean < 2e-3 && p99 < 2e-2, "visibility buffer and forward normals differ (mean {mean}, p99 {p99})");
    // The level-of-detail view colours the sphere by the level the culling pass chose, in every
    // pipeline: full detail white, a coarser level its own colour (`shaders/include/lod_debug.glsl`).
    const COLORS: [[f32; 3]; 5] = [[0.9, 0.9, 0.9], [0.1, 0.3, 1.0], [0.1, 0.9, 0.2], [1.0, 0.85, 0.1], [1.0, 0.15, 0.1]];
    app.world.resource_mut::<RenderSettings>().debug_view = DebugView::Lod;
    for pixels in [0.0, 8.0] {
        set_lod(&mut app, pixels);
        for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
            app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
            let (stats, depth) = settle(&mut app);
            let level = stats.lod_instances.iter().position(|&n| n == 1).expect("the sphere is drawn once");
            assert_eq!(level > 0, pixels > 0.0, "{pipeline:?} at {pixels} px: level {level}");
            let hdr = renderer(&mut app).read_hdr().expect("read back the HDR target");
            let covered: Vec<_> = hdr.iter().zip(&depth).filter(|(_, d)| **d > 0.0).map(|(p, _)| *p).collect();
            assert!(covered.len() > 500, "{pipeline:?}: the sphere covers {} pixels", covered.len());
            // Within the G-buffer's 8-bit sRGB albedo in deferred.
            let off = |p: &&[f32; 4]| (0..3).any(|c| (p[c] - COLORS[level][c]).abs() > 0.01);
            let wrong = covered.iter().filter(off).count();
            let first = covered.iter().find(off);
            assert_eq!(wrong, 0, "{pipeline:?} at {pixels} px: {wrong} of {} pixels not level {level}'s colour ({first:?})", covered.len());
        }
    }
    assert_no_validation_errors(&mut app);
}

/// A far skinned tube whose pose changes every frame skins only the vertices of the coarsest
/// level culling can pick for it (`render/src/skinning`): fewer vertices are skinned, and the
/// frame is the same, depth and colour, bit for bit, as with every vertex skinned, in forward
/// and in the visibility buffer (which rebuilds the triangles' attributes from the vertices).
#[test]
fn a_far_moving_skin_skins_only_its_levels_vertices_and_draws_the_same() {
    let settings =
        RenderSettings { pipeline: PipelineKind::Forward, aa: render::AntiAliasing::None, lod_pixels: 4.0, ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    let red = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.8, 0.2, 0.1, 1.0), 0.0, 0.5));
    let mut tube = crate::skinning::bendy_cylinder();
    tube.morph_targets.clear();
    let (tube, elbow) = crate::skinning::spawn_tube(&mut app, tube, red, Vec3::new(0.0, -1.0, -8.0), 0.0);
    let root = app.world.get::<engine::animation::Skin>(tube).unwrap().joints[0];
    app.world.spawn((DirectionalLight { illuminance: 3.0, ..Default::default() }, Transform::default().looking_at(-Vec3::Y, Vec3::Z)));
    app.world.spawn((Camera::default(), Transform::default()));
    // Four frames turning the tube's root joint and bending its elbow further each frame: a pose
    // set every frame that moves every vertex.
    let run = |app: &mut App, pipeline: PipelineKind, skin_levels: bool| {
        let mut s = app.world.resource_mut::<RenderSettings>();
        (s.pipeline, s.skin_levels) = (pipeline, skin_levels);
        let mut skinned = 0;
        for frame in 0..4 {
            let bend = Quat::from_rotation_z(-1.0 - 0.1 * frame as f32);
            app.world.get_mut::<Transform>(elbow).unwrap().rotation = bend;
            app.world.get_mut::<Transform>(root).unwrap().rotation = Quat::from_rotation_y(0.3 * frame as f32);
            app.update();
            skinned = app.world.resource::<RenderStats>().last.skinned_vertices;
        }
        let r = renderer(app);
        (skinned, r.read_depth().expect("read back the depth"), r.read_hdr().expect("read back the HDR target"))
    };
    for pipeline in [PipelineKind::Forward, PipelineKind::VisBuffer] {
        let (all, all_depth, all_hdr) = run(&mut app, pipeline, false);
        let (level, depth, hdr) = run(&mut app, pipeline, true);
        assert!(level > 0 && level < all, "{pipeline:?}: {level} of {all} vertices skinned");
        assert!(depth.iter().filter(|&&d| d > 0.0).count() > 40, "{pipeline:?}: the tube is on screen");
        assert!(depth == all_depth, "{pipeline:?}: the depth differs from the fully skinned frame's");
        assert!(hdr == all_hdr, "{pipeline:?}: the colour differs from the fully skinned frame's");
    }
    assert_no_validation_errors(&mut app);
}

/// A glTF file whose node 0 (a sphere of `fine` sectors) names node 1 (one of 8 sectors) as its
/// coarser level with `MSFT_lod`, and, with `bad`, a node 2 that has no mesh.
fn authored_lods_model(fine: u32, bad: bool) -> tests::gltf_files::Model {
    let mut b = tests::gltf_files::Builder::default();
    let mesh = |b: &mut tests::gltf_files::Builder, sectors: u32| {
        let m = shapes::uv_sphere(1.0, sectors, sectors / 2);
        let position = b.floats("VEC3", &m.positions);
        let normal = b.floats("VEC3", &m.normals);
        let indices: Vec<[u16; 1]> = m.indices.iter().map(|&i| [i as u16]).collect();
        let indices = b.u16s("SCALAR", &indices);
        serde_json::json!({ "primitives": [{ "attributes": { "POSITION": position, "NORMAL": normal }, "indices": indices }] })
    };
    let (full, coarse) = (mesh(&mut b, fine), mesh(&mut b, 8));
    let ids: Vec<usize> = if bad { vec![2, 1] } else { vec![1] };
    let mut nodes = vec![serde_json::json!({ "mesh": 0, "extensions": { "MSFT_lod": { "ids": ids } } }), serde_json::json!({ "mesh": 1 })];
    if bad {
        nodes.push(serde_json::json!({}));
    }
    b.finish(serde_json::json!({
        "extensionsUsed": ["MSFT_lod"],
        "meshes": [full, coarse],
        "nodes": nodes,
        "scenes": [{ "nodes": [0] }],
        "scene": 0,
    }))
}

/// A glTF file's own levels of detail (`MSFT_lod`) become its mesh's levels: the loader attaches
/// them (a named node without a mesh is left out), the upload appends their vertices and
/// measures their error, and a far instance draws the authored level's triangles, in place of
/// levels the simplifier would make.
#[test]
fn a_gltf_files_own_levels_of_detail_are_drawn_far_away() {
    let scene = authored_lods_model(64, true).load().expect("the file loads");
    let (full, _) = &scene.meshes[0][0];
    let coarse = scene.meshes[1][0].0.triangle_count();
    assert_eq!(full.lods.len(), 1, "node 2 has no mesh: only node 1's is a level");
    assert_eq!(full.lods[0].triangle_count(), coarse);
    let (data, _) = plugins::validate::mesh_data(full).expect("the mesh is valid");
    let lods = data.lods.as_ref().expect("levels");
    assert_eq!((lods.levels(), lods.counts[0] as usize), (1, 3 * coarse), "the authored level, not simplified ones");
    assert!(lods.errors[0] > 0.002 && lods.errors[0] < 0.05, "an eight-sided sphere strays a few percent: {}", lods.errors[0]);
    assert_eq!(data.vertices.len(), full.positions.len() + full.lods[0].positions.len(), "the level's vertices follow the mesh's");

    let settings = RenderSettings { pipeline: PipelineKind::Forward, aa: render::AntiAliasing::None, ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    let root = authored_lods_model(64, false).load().expect("the file loads").spawn(&mut app.world);
    app.world.entity_mut(root).insert(Transform::from_xyz(0.0, 0.0, -4.0));
    app.world.spawn((Camera::default(), Transform::default()));
    let (near, _) = settle(&mut app);
    assert_eq!(near.lod_instances[0], 1, "near: the full sphere: {near:?}");
    app.world.entity_mut(root).insert(Transform::from_xyz(0.0, 0.0, -60.0));
    let (far, _) = settle(&mut app);
    assert_eq!((far.lod_instances[1], far.triangles), (1, coarse as u64), "far: the authored level's triangles: {far:?}");
    assert_no_validation_errors(&mut app);
}

/// The level `shaders/cull.comp` picks for an instance that drew `kept` last, where a level's
/// error covers `scale × error` pixels: the coarsest within `limit`, but coarser than `kept`
/// only within the hysteresis band.
fn replay(lods: &MeshLods, scale: f32, limit: f32, kept: usize) -> usize {
    let within = |l: f32| (0..lods.levels()).take_while(|&k| lods.errors[k] * scale <= l).count();
    let fits = within(limit);
    if fits < kept { fits } else { kept.max(within(limit * LOD_HYSTERESIS)) }
}

#[test]
fn an_instance_in_the_hysteresis_band_keeps_the_level_it_came_with() {
    let mut app = gpu_app(64, 64, RenderSettings::default());
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::splat(0.6), 0.0, 0.5));
    let mesh = sphere();
    let data = plugins::validate::mesh_data(&mesh).expect("a valid sphere").0;
    let lods = MeshLods::generate(&data.vertices, &data.indices, &[]);
    assert!(lods.levels() >= 2, "the sphere has levels: {lods:?}");
    let handle = app.world.resource_mut::<Assets<Mesh>>().add(mesh);
    let ball = app.world.spawn((MeshInstance { mesh: handle, material: grey }, Transform::from_xyz(0.0, 0.0, -3.0))).id();
    app.world.spawn((Camera::default(), Transform::default()));
    // Pixels per unit of relative error at distance d (the unit sphere's bounds: a diagonal of
    // 2√3, nearest at d − 1; the projection's scale 1 / tan(30°), 64 pixels high).
    let scale = |d: f32| 2.0 * 3f32.sqrt() * 0.5 * 64.0 / (30f32.to_radians().tan() * (d - 1.0));
    let limit = 1.0;
    // A distance where level k's error covers 0.875 px (inside the band), coming from near
    // (level 0) and from far (the coarsest level) give different levels.
    let far_level = lods.levels();
    let case = (0..lods.levels())
        .map(|k| 1.0 + 2.0 * 3f32.sqrt() * 0.5 * 64.0 * lods.errors[k] / (30f32.to_radians().tan() * 0.875 * limit))
        .find(|&d| replay(&lods, scale(d), limit, 0) != replay(&lods, scale(d), limit, far_level))
        .expect("some level's band separates the two histories");
    let level_at = |app: &mut App, d: f32| {
        app.world.get_mut::<Transform>(ball).unwrap().translation.z = -d;
        let (stats, _) = settle(app);
        stats.lod_instances.iter().position(|&n| n == 1).expect("the ball is drawn once")
    };
    level_at(&mut app, 1.05);
    let from_near = level_at(&mut app, case);
    level_at(&mut app, 500.0);
    let from_far = level_at(&mut app, case);
    assert_eq!(from_near, replay(&lods, scale(case), limit, 0), "from near at {case} m");
    assert_eq!(from_far, replay(&lods, scale(case), limit, far_level), "from far at {case} m");
    assert!(from_far > from_near, "the band keeps the coarser level coming in ({from_far}) and the finer going out ({from_near})");
    assert_no_validation_errors(&mut app);
}
