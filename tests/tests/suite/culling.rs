//! GPU culling (`render/src/culling`) on lavapipe: culled images equal unculled ones in every
//! pipeline and with shadow maps; frustum culling counts what a CPU reference counts; a wall
//! hides the boxes behind it and the statistics say so; whatever it hid shows in the very frame
//! the wall goes or the camera turns; freezing the culling view keeps culling against it; a
//! frame where nothing changed uploads nothing; the depth pyramid equals a CPU reduction of the
//! depth, level by level, at an odd size; a frame whose commands repeat submits its command
//! buffer again (`render::gpu::commands`), and the images equal those of recording every frame.
//!
//! Tolerance between culling modes: mean absolute error ≤ 1e-5 and 99th percentile ≤ 1e-4 on
//! the HDR target (the same instances drawn, only by other commands; measured: 0).

use engine::prelude::*;
use plugins::{RenderSettings, RenderStats};
use render::{CullingMode, CullingStats, PipelineKind, Tier};
use tests::{assert_no_validation_errors, error_stats, gpu_app, gpu_app_at, renderer};

const SIZE: (u32, u32) = (160, 120);

/// The street: a ground, a wall across it, boxes hidden behind the wall, boxes in front of it,
/// boxes behind the camera, a lit sun; optionally an alpha-tested lattice, a glass pane and a
/// double-sided quad in front, so every batch and the ordered glass are drawn.
struct Street {
    wall: Entity,
    camera: Entity,
    hidden: usize,
    front: usize,
    behind: usize,
    /// Instances besides the boxes and the wall (ground, lattice, glass, quad).
    others: usize,
}

fn add_mesh(app: &mut App, m: Mesh) -> Handle<Mesh> {
    app.world.resource_mut::<Assets<Mesh>>().add(m)
}

fn add_material(app: &mut App, m: Material) -> Handle<Material> {
    app.world.resource_mut::<Assets<Material>>().add(m)
}

fn street(app: &mut App, extras: bool) -> Street {
    let grey = add_material(app, Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.8));
    let red = add_material(app, Material::from_color(Vec4::new(0.8, 0.2, 0.1, 1.0), 0.0, 0.5));
    let ground = add_mesh(app, shapes::plane(40.0, 40.0, 1, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    let wall_mesh = add_mesh(app, shapes::cuboid(Vec3::new(8.0, 6.0, 0.3), 1.0));
    let wall = app.world.spawn((MeshInstance { mesh: wall_mesh, material: grey }, Transform::from_xyz(0.0, 3.0, 2.0))).id();
    let cube = add_mesh(app, shapes::cuboid(Vec3::splat(0.8), 1.0));
    let mut boxes = |positions: &[Vec3]| {
        for &at in positions {
            app.world.spawn((MeshInstance { mesh: cube, material: red }, Transform::from_translation(at)));
        }
        positions.len()
    };
    let hidden: Vec<Vec3> = (0..12).map(|i| Vec3::new(-2.4 + (i % 4) as f32 * 1.6, 0.4, -1.0 - (i / 4) as f32 * 2.0)).collect();
    let hidden = boxes(&hidden);
    let front = boxes(&[Vec3::new(-2.0, 0.4, 4.5), Vec3::new(0.0, 0.4, 4.0), Vec3::new(2.0, 0.4, 4.5)]);
    let behind = boxes(&[-2.0, -1.0, 0.0, 1.0, 2.0].map(|x| Vec3::new(x * 1.5, 0.4, 13.0)));
    let mut others = 1;
    if extras {
        // Alpha-tested lattice (double-sided), glass, and a double-sided opaque quad.
        let lattice: Vec<u8> = (0..64).flat_map(|i| if (i % 8 + i / 8) % 2 == 0 { [40, 160, 60, 255] } else { [0, 0, 0, 0] }).collect();
        let image = app.world.resource_mut::<Assets<Image>>().add(Image::from_rgba8(8, 8, lattice, ColorSpace::Srgb).unwrap());
        let masked = add_material(
            app,
            Material { base_color_texture: Some(image), alpha_mode: AlphaMode::Mask(0.5), double_sided: true, ..Default::default() },
        );
        let glass =
            add_material(app, Material { base_color: Vec4::new(0.2, 0.4, 0.9, 0.4), alpha_mode: AlphaMode::Blend, ..Default::default() });
        let two_sided = add_material(app, Material { double_sided: true, ..Material::from_color(Vec4::new(0.9, 0.8, 0.2, 1.0), 0.0, 0.6) });
        let quad = add_mesh(app, shapes::plane(1.2, 1.2, 1, 1.0));
        let upright = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
        for (material, at) in
            [(masked, Vec3::new(-1.0, 1.0, 5.5)), (glass, Vec3::new(0.8, 1.0, 5.8)), (two_sided, Vec3::new(2.8, 1.0, 5.0))]
        {
            app.world.spawn((MeshInstance { mesh: quad, material }, Transform::from_translation(at).with_rotation(upright)));
        }
        others += 3;
    }
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.4, -1.0, -0.3), Vec3::Z),
    ));
    let camera =
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.6, 8.0).looking_at(Vec3::new(0.0, 1.0, 0.0), Vec3::Y))).id();
    Street { wall, camera, hidden, front, behind, others }
}

/// Turns the camera half a turn about the vertical.
fn turn_round(app: &mut App, camera: Entity) {
    let mut t = app.world.get_mut::<Transform>(camera).unwrap();
    t.rotation = Quat::from_rotation_y(std::f32::consts::PI) * t.rotation;
}

fn set_culling(app: &mut App, mode: CullingMode) {
    app.world.resource_mut::<RenderSettings>().culling = mode;
}

fn hdr(app: &mut App) -> Vec<[f32; 4]> {
    renderer(app).read_hdr().expect("read back the HDR target")
}

/// Renders `frames` frames in `mode` and returns the last image.
fn render_in(app: &mut App, mode: CullingMode, frames: usize) -> Vec<[f32; 4]> {
    set_culling(app, mode);
    for _ in 0..frames {
        app.update();
    }
    hdr(app)
}

fn assert_same(a: &[[f32; 4]], b: &[[f32; 4]], what: &str) {
    let (mean, p99) = error_stats(a, b, |_| true);
    assert!(mean <= 1e-5 && p99 <= 1e-4, "{what}: culled and unculled images differ (mean {mean}, p99 {p99})");
}

/// The culling statistics of a frame of the scene as it is (four more frames are rendered:
/// statistics come back two frames late).
fn stats(app: &mut App) -> CullingStats {
    renderer(app).finish();
    for _ in 0..4 {
        app.update();
    }
    app.world.resource::<RenderStats>().last.culling
}

#[test]
fn culled_images_equal_unculled_ones_in_every_pipeline() {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings::default());
    street(&mut app, true);
    for pipeline in PipelineKind::ALL {
        app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
        let off = render_in(&mut app, CullingMode::Off, 2);
        let draws = app.world.resource::<RenderStats>().last.draw_calls;
        assert!(draws > 0, "{pipeline:?}: the frame records indirect draws");
        for mode in [CullingMode::Frustum, CullingMode::Occlusion] {
            let culled = render_in(&mut app, mode, 3);
            assert_same(&off, &culled, &format!("{pipeline:?}, {mode:?}"));
        }
    }
    assert_no_validation_errors(&mut app);
}

#[test]
fn shadow_maps_drawn_from_culled_lists_equal_unculled_ones() {
    let mut app = gpu_app_at(SIZE.0, SIZE.1, RenderSettings { pipeline: PipelineKind::Deferred, ..Default::default() }, Tier::NoRayTracing);
    street(&mut app, true);
    app.world.spawn((PointLight { intensity: 30.0, range: Some(12.0), ..Default::default() }, Transform::from_xyz(1.0, 2.5, 5.0)));
    let off = render_in(&mut app, CullingMode::Off, 2);
    assert!(app.world.resource::<RenderStats>().last.shadow_map_views >= 7, "the sun's view and the point light's six");
    let culled = render_in(&mut app, CullingMode::Occlusion, 3);
    assert_same(&off, &culled, "shadow maps");
    assert_no_validation_errors(&mut app);
}

/// Renders the next frame with occlusion culling and asserts it equals an unculled one of the
/// same scene (what was hidden shows in that very frame); culling stays on.
fn assert_next_frame_shows_everything(app: &mut App, what: &str) {
    app.update();
    let shown = hdr(app);
    let reference = render_in(app, CullingMode::Off, 1);
    assert_same(&reference, &shown, what);
    set_culling(app, CullingMode::Occlusion);
}

#[test]
fn a_wall_hides_the_boxes_behind_it_and_they_show_in_the_frame_it_goes() {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { pipeline: PipelineKind::VisBuffer, ..Default::default() });
    let s = street(&mut app, false);
    let total = (s.hidden + s.front + s.behind + s.others + 1) as u64;
    set_culling(&mut app, CullingMode::Occlusion);
    app.update();
    let c = stats(&mut app);
    let lists = renderer(&mut app).read_culled_lists().unwrap().expect("a frame was culled");
    assert!(lists.second.is_empty(), "in a still frame nothing is newly visible: {lists:?}");
    assert_eq!(lists.first.len() as u64, c.after_occlusion, "{lists:?}");
    assert_eq!(c.mode, CullingMode::Occlusion);
    assert_eq!(c.instances, total, "{c:?}");
    assert_eq!(c.after_frustum, total - s.behind as u64, "the boxes behind the camera are outside the frustum: {c:?}");
    assert_eq!(c.after_occlusion, (s.front + s.others + 1) as u64, "the wall hides every box behind it: {c:?}");
    assert_eq!(c.dropped, 0);

    // A frame where nothing changed uploads nothing, with culling on.
    app.update();
    assert_eq!(app.world.resource::<RenderStats>().last.bytes_uploaded, 0, "a quiet frame uploads nothing");

    // The wall goes: the boxes behind it are drawn in that very frame.
    app.world.despawn(s.wall);
    assert_next_frame_shows_everything(&mut app, "the frame the wall went");
    let c = stats(&mut app);
    assert_eq!(c.after_occlusion, (s.hidden + s.front + s.others) as u64, "{c:?}");

    // The camera turns round: the boxes that were behind it show in the frame it turns.
    turn_round(&mut app, s.camera);
    assert_next_frame_shows_everything(&mut app, "the frame the camera turned");
    assert_no_validation_errors(&mut app);
}

#[test]
fn a_frozen_culling_view_keeps_culling_against_it() {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { culling: CullingMode::Frustum, ..Default::default() });
    let s = street(&mut app, false);
    app.update();
    let before = stats(&mut app);
    app.world.resource_mut::<RenderSettings>().freeze_culling = true;
    app.update();
    turn_round(&mut app, s.camera);
    let frozen = stats(&mut app);
    assert!(frozen.frozen);
    assert_eq!(frozen.after_frustum, before.after_frustum, "culled against the frozen view, not the turned camera");
    // Looking back, the boxes behind the old view are missing: the image differs from an
    // unfrozen one.
    let missing = hdr(&mut app);
    app.world.resource_mut::<RenderSettings>().freeze_culling = false;
    let thawed = render_in(&mut app, CullingMode::Frustum, 1);
    let (mean, _) = error_stats(&missing, &thawed, |_| true);
    assert!(mean > 1e-3, "the frozen view hides what the camera now sees (mean difference {mean})");
    let c = stats(&mut app);
    assert_eq!(c.after_frustum, (s.behind + s.others) as u64, "turned round: the ground and the boxes that were behind: {c:?}");
    assert_no_validation_errors(&mut app);
}

/// The reverse-Z clip-space planes of `view_proj` (Gribb and Hartmann), and whether the box
/// reaches inside all of them: written here from the definition, not from the shader.
fn box_in_frustum(view_proj: Mat4, lo: Vec3, hi: Vec3) -> bool {
    let r = |i: usize| view_proj.row(i);
    let planes = [r(3) + r(0), r(3) - r(0), r(3) + r(1), r(3) - r(1), r(2), r(3) - r(2)];
    planes.iter().all(|p| {
        // The corner farthest along the plane's normal.
        let corner =
            Vec3::new(if p.x >= 0.0 { hi.x } else { lo.x }, if p.y >= 0.0 { hi.y } else { lo.y }, if p.z >= 0.0 { hi.z } else { lo.z });
        p.truncate().dot(corner) + p.w >= 0.0
    })
}

#[test]
fn frustum_culling_counts_what_a_cpu_reference_counts() {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { culling: CullingMode::Frustum, ..Default::default() });
    let material = add_material(&mut app, Material::from_color(Vec4::ONE, 0.0, 0.5));
    let cube = add_mesh(&mut app, shapes::cuboid(Vec3::splat(0.5), 1.0));
    let mut rng = 0x2545_f491u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut boxes = Vec::new();
    for _ in 0..400 {
        let at = Vec3::new(next() * 40.0 - 20.0, next() * 10.0 - 2.0, next() * 40.0 - 20.0);
        boxes.push(at);
        app.world.spawn((MeshInstance { mesh: cube, material }, Transform::from_translation(at)));
    }
    let view = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::new(-4.0, 1.0, -6.0), Vec3::Y);
    let camera = Camera::default();
    app.world.spawn((camera, view));
    app.update();
    let c = stats(&mut app);
    let view_proj = camera.projection(SIZE.0 as f32 / SIZE.1 as f32) * view.compute_matrix().inverse();
    let expected = boxes.iter().filter(|&&at| box_in_frustum(view_proj, at - 0.25, at + 0.25)).count() as u64;
    assert!(expected > 20 && expected < 380, "the view sees part of the scatter ({expected})");
    assert_eq!(c.instances, 400);
    assert_eq!(c.after_frustum, expected, "{c:?}");
    assert_eq!(c.after_occlusion, expected, "no occlusion culling in this mode");
    assert_no_validation_errors(&mut app);
}

/// The pyramid's level `level` from the one below (`below`, `bw` × `bh`; level 0 from the depth),
/// each texel the farthest (smallest, reverse Z) of the 2×2 below it, clamped at the edges.
fn reduce(below: &[f32], bw: usize, bh: usize) -> (Vec<f32>, usize, usize) {
    let (w, h) = (bw.div_ceil(2), bh.div_ceil(2));
    let at = |x: usize, y: usize| below[y.min(bh - 1) * bw + x.min(bw - 1)];
    let level = (0..w * h)
        .map(|i| (i % w, i / w))
        .map(|(x, y)| at(2 * x, 2 * y).min(at(2 * x + 1, 2 * y)).min(at(2 * x, 2 * y + 1)).min(at(2 * x + 1, 2 * y + 1)));
    (level.collect(), w, h)
}

#[test]
fn the_depth_pyramid_equals_a_cpu_reduction_of_the_depth() {
    // An odd size: levels of odd width and height, and more levels than one dispatch writes.
    let (w, h) = (150, 77);
    let settings = RenderSettings { aa: render::AntiAliasing::None, culling: CullingMode::Occlusion, ..Default::default() };
    let mut app = gpu_app(w, h, settings);
    street(&mut app, false);
    // A still camera without jitter: by now the second phase draws nothing new, so the depth at
    // the end of the frame is the depth the pyramid was built from.
    for _ in 0..4 {
        app.update();
    }
    let depth = renderer(&mut app).read_depth().expect("read back the depth");
    let pyramid = renderer(&mut app).read_depth_pyramid().expect("read back the pyramid").expect("occlusion culling builds one");
    assert_eq!((pyramid.width, pyramid.height), (w, h));
    let pyramid = pyramid.depths;
    let (mut below, mut bw, mut bh) = (depth, w as usize, h as usize);
    let (mut offset, mut levels) = (0, 0);
    loop {
        let (level, lw, lh) = reduce(&below, bw, bh);
        let gpu = pyramid.get(offset..offset + level.len()).unwrap_or_else(|| panic!("level {levels} lies inside the pyramid"));
        if let Some(i) = (0..level.len()).find(|&i| gpu[i] != level[i]) {
            panic!("level {levels} ({lw}×{lh}), texel ({}, {}): {} on the GPU, {} on the CPU", i % lw, i / lw, gpu[i], level[i]);
        }
        offset += level.len();
        levels += 1;
        if (lw, lh) == (1, 1) {
            break;
        }
        (below, bw, bh) = (level, lw, lh);
    }
    assert_eq!(offset, pyramid.len(), "{levels} levels fill the pyramid");
    assert!(levels > 4, "more levels ({levels}) than one dispatch writes");
    assert_no_validation_errors(&mut app);
}

/// Renders `frames` frames, moving the camera a little before each when `moving`; returns the
/// last image and, frame by frame, whether its command buffer was submitted again as recorded.
fn frames_reused(app: &mut App, camera: Entity, frames: usize, moving: bool) -> (Vec<[f32; 4]>, Vec<bool>) {
    let mut reused = Vec::new();
    for _ in 0..frames {
        if moving {
            app.world.get_mut::<Transform>(camera).unwrap().translation.x += 0.05;
        }
        app.update();
        reused.push(app.world.resource::<RenderStats>().last.commands_reused);
    }
    (hdr(app), reused)
}

#[test]
fn a_frame_with_the_same_commands_submits_its_command_buffer_again() {
    // Two apps, one recording every frame: the images must not tell them apart.
    let settings = RenderSettings { pipeline: PipelineKind::Deferred, aa: render::AntiAliasing::Taa, ..Default::default() };
    let mut every = gpu_app(SIZE.0, SIZE.1, RenderSettings { reuse_commands: false, ..settings.clone() });
    let mut reusing = gpu_app(SIZE.0, SIZE.1, settings);
    let (e, r) = (street(&mut every, true), street(&mut reusing, true));
    let both = |every: &mut App, reusing: &mut App, moving: bool| {
        let recorded = frames_reused(every, e.camera, 6, moving);
        let reused = frames_reused(reusing, r.camera, 6, moving);
        assert_eq!(recorded.1, [false; 6], "recording every frame never reuses");
        assert_eq!(recorded.0, reused.0, "reused and recorded frames give the same image");
        reused.1
    };
    // Each of the two frame slots records twice (the first frame also sets things up) before
    // its commands repeat.
    assert_eq!(both(&mut every, &mut reusing, false), [false, false, false, false, true, true], "a still scene reuses");

    // A moving camera changes data (the camera record), not commands: once the frames that
    // start uploading it have passed (the first two, one a slot, and the third, whose first
    // barriers follow the second's last uses), frames reuse again.
    assert_eq!(both(&mut every, &mut reusing, true), [false, false, false, true, true, true], "a moving camera reuses");

    // A change of commands (a despawned wall: tables trimmed and uploaded) records again, and
    // frames reuse again once it is done.
    every.world.despawn(e.wall);
    reusing.world.despawn(r.wall);
    let reused = both(&mut every, &mut reusing, false);
    assert!(!reused[0], "the frame the wall went records its uploads");
    assert_eq!(&reused[4..], [true; 2], "{reused:?}");
    let words = reusing.world.resource::<RenderStats>().last.command_words;
    assert!(words > 100, "the log holds the frame's commands ({words} words)");
    assert_no_validation_errors(&mut every);
    assert_no_validation_errors(&mut reusing);
}
