//! Anti-aliasing on lavapipe: a scene of thin posts and slanted wires, displayed with each mode,
//! against a 4×4-supersampled render of the same scene (the mean of each 4×4 block of a render
//! at four times the size), in every pipeline; temporal anti-aliasing after 16 still frames;
//! MSAA (4×: lavapipe offers 1 and 4 samples) in forward and Forward+, also over a lit scene with
//! a decal, ray-traced shadows, ambient occlusion, glass and the sky.
//! Temporal anti-aliasing must also forget what went away: no trail behind a box that moved, a
//! new decal sharp within 3 frames and no ghost of a despawned one.

use engine::prelude::*;
use plugins::RenderSettings;
use plugins::decal::{Decal, DecalMaterial};
use render::{AntiAliasing, DebugView, DecalMethod, PipelineKind};
use tests::{assert_no_validation_errors, gpu_app, renderer};

const SIZE: (u32, u32) = (128, 96);

/// Pale posts (when `posts`) and slanted wires (flat albedo, so edges are the only detail)
/// against a dark sky: about 2.5-pixel posts and 1.5-pixel wires at 128×96. Shown in the albedo
/// view (flat colours) unless `lit` (flat too: no lights, the flat ambient colour). Nothing is
/// drawn yet: [`display_with`] renders it with each anti-aliasing mode in turn.
fn posts_and_wires_app(w: u32, h: u32, pipeline: PipelineKind, posts: bool, lit: bool) -> App {
    let settings = RenderSettings {
        pipeline,
        debug_view: if lit { DebugView::Lit } else { DebugView::Albedo },
        ambient: Vec3::splat(1.0),
        decal_method: DecalMethod::Off,
        clear_color: [0.02, 0.02, 0.03, 1.0],
        ..Default::default()
    };
    let mut app = gpu_app(w, h, settings);
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.9, 0.85, 0.7, 1.0), 0.0, 0.8));
    let post = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(0.12, 3.0, 0.12), 1.0));
    let wire = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(6.0, 0.08, 0.08), 1.0));
    for i in 0..if posts { 7 } else { 0 } {
        let x = -1.8 + i as f32 * 0.6;
        app.world.spawn((MeshInstance { mesh: post, material }, Transform::from_xyz(x, 0.0, -i as f32 * 0.2)));
    }
    for (i, angle) in [-0.35f32, -0.12, 0.08, 0.3].into_iter().enumerate() {
        let transform = Transform::from_xyz(0.0, -0.6 + i as f32 * 0.4, 0.3).with_rotation(Quat::from_rotation_z(angle));
        app.world.spawn((MeshInstance { mesh: wire, material }, transform));
    }
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app
}

/// The displayed image of `app`'s still view after `frames` frames with anti-aliasing `aa` (one
/// app renders every mode in turn: the view is still, and each mode's first frame starts its own
/// history, as `a_moving_box_leaves_no_trail_under_taa` and the soak's switches check).
fn display_with(app: &mut App, aa: AntiAliasing, frames: usize) -> Vec<u8> {
    app.world.resource_mut::<RenderSettings>().aa = aa;
    for _ in 0..frames {
        app.update();
    }
    assert_no_validation_errors(app);
    renderer(app).read_display().expect("the display image reads back")
}

/// The mean of each `factor`×`factor` block of an RGBA8 image `w` pixels wide, in [0, 1].
/// Blocks are averaged in linear light (what a pixel covering the block would gather), then
/// encoded back to sRGB: an average of sRGB values would make every partly covered pixel too
/// dark.
fn downsample(image: &[u8], w: u32, factor: u32) -> Vec<[f32; 3]> {
    let linear = |v: u8| {
        let v = v as f32 / 255.0;
        if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
    };
    let srgb = |v: f32| if v <= 0.0031308 { v * 12.92 } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    let (ow, oh) = (w / factor, image.len() as u32 / 4 / w / factor);
    let mut out = vec![[0.0f32; 3]; (ow * oh) as usize];
    for y in 0..oh * factor {
        for x in 0..ow * factor {
            let at = ((y * w + x) * 4) as usize;
            let o = &mut out[((y / factor) * ow + x / factor) as usize];
            for c in 0..3 {
                o[c] += linear(image[at + c]) / (factor * factor) as f32;
            }
        }
    }
    for o in &mut out {
        *o = o.map(srgb);
    }
    out
}

/// Mean absolute error against the reference over the pixels where it is not flat (an edge is
/// within the block), and the largest difference where it is flat.
fn error(image: &[u8], reference: &[[f32; 3]], flat: &[bool]) -> (f32, f32) {
    let mine = downsample(image, SIZE.0, 1);
    let (mut sum, mut n, mut flat_max) = (0.0f32, 0usize, 0.0f32);
    for (i, (a, b)) in mine.iter().zip(reference).enumerate() {
        let d = (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0;
        if flat[i] {
            flat_max = flat_max.max(d);
        } else {
            sum += d;
            n += 1;
        }
    }
    (sum / n.max(1) as f32, flat_max)
}

/// The 4×4-supersampled reference and which of its pixels are flat (the 4×4 block and its
/// neighbours' blocks are all sky or all wire: no edge near).
fn reference(pipeline: PipelineKind, posts: bool, lit: bool) -> (Vec<[f32; 3]>, Vec<bool>) {
    let big = display_with(&mut posts_and_wires_app(SIZE.0 * 4, SIZE.1 * 4, pipeline, posts, lit), AntiAliasing::None, 1);
    let reference = downsample(&big, SIZE.0 * 4, 4);
    // Flat: the 4×4 block and its neighbours' blocks are all sky or all wire (no edge near).
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    let flat: Vec<bool> = (0..h * w)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = reference[i as usize];
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (nx, ny) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                    let n = reference[(ny * w + nx) as usize];
                    (0..3).all(|k| (n[k] - c[k]).abs() < 0.002)
                })
            })
        })
        .collect();
    let edges = flat.iter().filter(|f| !**f).count();
    assert!(edges > 600, "{pipeline:?}: the posts and wires make edges ({edges} pixels)");
    (reference, flat)
}

/// The mean error at edges without anti-aliasing and with each post-process of `modes`, in
/// `pipeline` (posts or not), from one app and one supersampled reference, checking that each
/// leaves flat areas as they are.
fn edge_errors(pipeline: PipelineKind, posts: bool, modes: &[AntiAliasing]) -> (f32, Vec<f32>) {
    let (reference, flat) = reference(pipeline, posts, false);
    let mut app = posts_and_wires_app(SIZE.0, SIZE.1, pipeline, posts, false);
    let (plain, plain_flat) = error(&display_with(&mut app, AntiAliasing::None, 1), &reference, &flat);
    let errors = modes
        .iter()
        .map(|&aa| {
            let (post, post_flat) = error(&display_with(&mut app, aa, 1), &reference, &flat);
            eprintln!(
                "{pipeline:?}, posts {posts}: mean error at edges, none {plain:.4}, {} {post:.4} ({:.2}x); flat areas max {plain_flat:.4} / {post_flat:.4}",
                aa.name(),
                plain / post
            );
            assert!(post_flat <= plain_flat + 0.01, "{pipeline:?}: {aa:?} leaves flat areas alone: {plain_flat} / {post_flat}");
            post
        })
        .collect();
    (plain, errors)
}

/// FXAA (in the tone-mapping pass) and SMAA (passes of their own) are post-processes over the
/// displayed image whatever the pipeline drew it: tested in two (the third pipeline's image is
/// checked against forward's by `all_pipelines_render_the_same_scene_alike_and_the_same_depth`),
/// both against one reference.
#[test]
fn fxaa_and_smaa_bring_slanted_wires_and_posts_closer_to_the_supersampled_image() {
    // FXAA and SMAA filter the displayed image after any pipeline alike: one pipeline stands for
    // all (the TAA test below compares FXAA with the reference in three).
    let pipeline = PipelineKind::Deferred;
    // Slanted wires: the stair steps FXAA and SMAA are made for. SMAA measured 3.2x, FXAA
    // 1.4x.
    let (plain, e) = edge_errors(pipeline, false, &[AntiAliasing::Fxaa, AntiAliasing::Smaa]);
    assert!(e[0] <= plain * 0.8, "{pipeline:?}: FXAA reduces the error along slanted wires by 20 %: none {plain}, FXAA {}", e[0]);
    assert!(e[1] <= plain * 0.5, "{pipeline:?}: SMAA halves the error along slanted wires: none {plain}, SMAA {}", e[1]);
    // With upright posts: their edges are straight columns with no steps to find, which
    // both leave as they are, so the gain over the whole image is smaller (SMAA measured
    // 1.16x).
    let (plain, e) = edge_errors(pipeline, true, &[AntiAliasing::Fxaa, AntiAliasing::Smaa]);
    assert!(e[0] <= plain * 0.93, "{pipeline:?}: FXAA reduces the error with posts by 7 %: none {plain}, FXAA {}", e[0]);
    assert!(e[1] <= plain * 0.9, "{pipeline:?}: SMAA reduces the error with posts by 10 %: none {plain}, SMAA {}", e[1]);
}

#[test]
fn taa_after_sixteen_still_frames_comes_closer_to_the_supersampled_image_than_fxaa_in_every_pipeline() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        let (reference, flat) = reference(pipeline, true, true);
        let mut app = posts_and_wires_app(SIZE.0, SIZE.1, pipeline, true, true);
        let (plain, plain_flat) = error(&display_with(&mut app, AntiAliasing::None, 1), &reference, &flat);
        let (fxaa, _) = error(&display_with(&mut app, AntiAliasing::Fxaa, 1), &reference, &flat);
        let taa_image = display_with(&mut app, AntiAliasing::Taa, 16);
        let (taa, taa_flat) = error(&taa_image, &reference, &flat);
        eprintln!(
            "{pipeline:?}, lit: mean error at edges, none {plain:.4}, FXAA {fxaa:.4}, TAA {taa:.4} ({:.2}x); flat areas max {plain_flat:.4} / {taa_flat:.4}",
            plain / taa
        );
        // Measured 2.8x (none 0.091, FXAA 0.072, TAA 0.033 in every pipeline).
        assert!(taa <= plain * 0.5, "{pipeline:?}: TAA halves the error at edges: none {plain}, TAA {taa}");
        assert!(taa < fxaa, "{pipeline:?}: TAA beats FXAA: {taa} against {fxaa}");
        assert!(taa_flat <= plain_flat + 0.02, "{pipeline:?}: TAA leaves flat areas alone: {plain_flat} / {taa_flat}");
    }
}

/// The posts and wires have no light to cull, so forward and Forward+ draw them alike: tested in
/// Forward+ (the lit corner below runs both).
#[test]
fn msaa_comes_closer_to_the_supersampled_image_in_forward_plus() {
    let pipeline = PipelineKind::ForwardPlus;
    let (reference, flat) = reference(pipeline, true, true);
    let mut app = posts_and_wires_app(SIZE.0, SIZE.1, pipeline, true, true);
    let (plain, plain_flat) = error(&display_with(&mut app, AntiAliasing::None, 1), &reference, &flat);
    let (msaa, msaa_flat) = error(&display_with(&mut app, AntiAliasing::Msaa4, 1), &reference, &flat);
    eprintln!(
        "{pipeline:?}, lit: mean error at edges, none {plain:.4}, MSAA 4x {msaa:.4} ({:.2}x); flat areas max {plain_flat:.4} / {msaa_flat:.4}",
        plain / msaa
    );
    assert!(msaa <= plain * 0.5, "{pipeline:?}: MSAA 4x halves the error at edges: none {plain}, MSAA {msaa}");
    assert!(msaa_flat <= plain_flat + 0.01, "{pipeline:?}: MSAA leaves flat areas alone: {plain_flat} / {msaa_flat}");
}

/// A lit corner: a ground with a dark decal (applied by the clustered decal pass, so the prepass
/// also writes ids), a box that casts a ray-traced shadow over it, a chrome ball that reflects
/// them (traced reflections), ambient occlusion, a glass pane, and the procedural sky behind;
/// shown with [`display_with`] (two frames a mode).
fn lit_corner(w: u32, h: u32, pipeline: PipelineKind) -> App {
    // Levels of detail off: their limit is in pixels, so the supersampled reference would draw
    // finer levels (and lift its rays less) than the image it is compared with.
    let settings = RenderSettings { pipeline, decal_method: DecalMethod::Clustered, lod_pixels: 0.0, ..Default::default() };
    let renderer_settings =
        render::RendererSettings { shadow_maps: tests::TEST_SHADOW_MAPS, environment_resolution: 32, ..Default::default() };
    let mut app = tests::gpu_app_with(w, h, settings, &renderer_settings);
    app.world.resource_mut::<RenderSettings>().occlusion = render::OcclusionSettings::default();
    app.insert_resource(engine::environment::Environment::default());
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.55, 1.0), 0.0, 0.8));
    let glass = Material { alpha_mode: AlphaMode::Blend, ..Material::from_color(Vec4::new(0.3, 0.6, 0.9, 0.5), 0.0, 0.3) };
    let glass = app.world.resource_mut::<Assets<Material>>().add(glass);
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(6.0, 6.0, 1, 1.0));
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::splat(0.8), 1.0));
    let pane = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(0.9, 0.9, 1, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    app.world
        .spawn((MeshInstance { mesh: cube, material: grey }, Transform::from_xyz(0.6, 0.4, 0.0).with_rotation(Quat::from_rotation_y(0.5))));
    let upright = Quat::from_rotation_y(-0.4) * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    app.world.spawn((MeshInstance { mesh: pane, material: glass }, Transform::from_xyz(-1.1, 0.6, 0.8).with_rotation(upright)));
    let chrome = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.95, 0.93, 0.9, 1.0), 1.0, 0.05));
    let ball = app.world.resource_mut::<Assets<Mesh>>().add(shapes::uv_sphere(0.35, 32, 16));
    app.world.spawn((MeshInstance { mesh: ball, material: chrome }, Transform::from_xyz(-0.3, 0.35, -0.7)));
    let dark = DecalMaterial { base_color: Some(Vec4::new(0.05, 0.02, 0.02, 1.0)), ..Default::default() };
    let dark = app.world.resource_mut::<Assets<DecalMaterial>>().add(dark);
    let on_ground = Transform::from_xyz(-0.4, 0.0, 1.0)
        .with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(0.9, 0.6, 0.3));
    app.world.spawn((Decal::new(dark), on_ground));
    app.world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(-0.6, -1.0, -0.2), Vec3::Y),
    ));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.6, 4.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));
    app
}

/// MSAA resolves what the lit corner shows: where the image without anti-aliasing already
/// equals the supersampled one (inside surfaces, shadows, the decal, the glass, the sky) MSAA's
/// does too, so the per-pixel inputs reach every sample they belong to; at the edges it comes
/// closer.
#[test]
fn msaa_keeps_decals_shadows_glass_and_the_sky_and_smooths_their_edges() {
    for pipeline in [PipelineKind::Forward, PipelineKind::ForwardPlus] {
        let reference = downsample(&display_with(&mut lit_corner(SIZE.0 * 4, SIZE.1 * 4, pipeline), AntiAliasing::None, 2), SIZE.0 * 4, 4);
        let mut app = lit_corner(SIZE.0, SIZE.1, pipeline);
        let mut differences = |aa| {
            let image = downsample(&display_with(&mut app, aa, 2), SIZE.0, 1);
            image.iter().zip(&reference).map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0).collect::<Vec<f32>>()
        };
        let (plain, msaa) = (differences(AntiAliasing::None), differences(AntiAliasing::Msaa4));
        let edges: Vec<usize> = (0..plain.len()).filter(|&i| plain[i] > 0.02).collect();
        let inside: Vec<usize> = (0..plain.len()).filter(|&i| plain[i] <= 0.01).collect();
        let mean = |d: &[f32]| edges.iter().map(|&i| d[i]).sum::<f32>() / edges.len() as f32;
        let inside_most = inside.iter().map(|&i| msaa[i]).fold(0.0f32, f32::max);
        eprintln!(
            "{pipeline:?}: {} edge pixels, mean error none {:.4}, MSAA 4x {:.4}; {} pixels inside, MSAA's largest error {inside_most:.4}",
            edges.len(),
            mean(&plain),
            mean(&msaa),
            inside.len()
        );
        assert!(edges.len() > 200 && inside.len() > 5000, "{pipeline:?}: the corner has edges and surfaces");
        // Measured 0.82x: the edges of geometry are smoothed; those of shadows, the decal and
        // the glass are per pixel (crate::msaa).
        assert!(mean(&msaa) <= 0.85 * mean(&plain), "{pipeline:?}: MSAA smooths the edges");
        assert!(inside_most <= 0.05, "{pipeline:?}: MSAA keeps what is inside surfaces: {inside_most}");
    }
}

/// A dark wall facing the camera (at z = −1) in a TAA app, and the camera.
fn wall_app(pipeline: PipelineKind) -> App {
    let settings = RenderSettings { pipeline, aa: AntiAliasing::Taa, ambient: Vec3::splat(1.0), ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.35, 0.35, 0.4, 1.0), 0.0, 0.9));
    let wall = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let facing_camera = Transform::from_xyz(0.0, 0.0, -1.0).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    app.world.spawn((MeshInstance { mesh: wall, material: grey }, facing_camera));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app
}

/// The largest difference (in [0, 1]) between two RGBA8 images over the pixels where `flat`
/// holds, and how many there are.
fn largest_difference(a: &[u8], b: &[u8], flat: impl Fn(usize) -> bool) -> (f32, usize) {
    let mut n = 0;
    let mut most = 0.0f32;
    for i in (0..(SIZE.0 * SIZE.1) as usize).filter(|&i| flat(i)) {
        n += 1;
        most = most.max((0..3).map(|c| (a[i * 4 + c] as f32 - b[i * 4 + c] as f32).abs() / 255.0).fold(0.0, f32::max));
    }
    (most, n)
}

/// Whether the 5×5 neighbourhood of pixel `i` of RGBA8 `image` is one colour (within 2/255).
fn flat_around(image: &[u8], i: usize) -> bool {
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    let (x, y) = (i as i32 % w, i as i32 / w);
    (-2..=2).all(|dy| {
        (-2..=2).all(|dx| {
            let (nx, ny) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
            let j = (ny * w + nx) as usize * 4;
            (0..3).all(|c| (image[j + c] as i32 - image[i * 4 + c] as i32).abs() <= 2)
        })
    })
}

fn display(app: &mut App) -> Vec<u8> {
    assert_no_validation_errors(app);
    renderer(app).read_display().expect("the display image reads back")
}

/// A pale box slides across the wall for 12 frames (a box width every 4), then stops: 8 frames
/// later the TAA image equals the un-anti-aliased one wherever that is flat (all but the box's
/// edges), so nothing is left along its path.
#[test]
fn a_moving_box_leaves_no_trail_under_taa() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred] {
        let mut app = wall_app(pipeline);
        let pale = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.95, 0.9, 0.8, 1.0), 0.0, 0.9));
        let cube = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::splat(0.5), 1.0));
        let mover = app.world.spawn((MeshInstance { mesh: cube, material: pale }, Transform::from_xyz(-1.6, 0.0, -0.5))).id();
        for i in 0..12 {
            app.world.entity_mut(mover).insert(Transform::from_xyz(-1.6 + 0.125 * i as f32, 0.0, -0.5));
            app.update();
        }
        for _ in 0..8 {
            app.update();
        }
        let taa = display(&mut app);
        app.world.resource_mut::<RenderSettings>().aa = AntiAliasing::None;
        app.update();
        let plain = display(&mut app);
        let (most, n) = largest_difference(&taa, &plain, |i| flat_around(&plain, i));
        eprintln!("{pipeline:?}: 8 frames after the box stopped, away from its edges ({n} px): largest difference {most:.4}");
        assert!(n > 5000, "{pipeline:?}: most of the image is flat: {n}");
        assert!(most <= 0.02, "{pipeline:?}: no trail behind the box: {most}");
    }
}

/// A dark decal spawned on the wall under TAA shows at the un-anti-aliased image's contrast
/// within 3 frames (the history is clipped to what the neighbourhood shows now), and 3 frames
/// after it is despawned nothing of it is left.
#[test]
fn a_spawned_decal_is_sharp_within_three_frames_and_a_despawned_one_leaves_no_ghost() {
    let mut app = wall_app(PipelineKind::Deferred);
    let material = DecalMaterial { base_color: Some(Vec4::new(0.02, 0.02, 0.02, 1.0)), ..Default::default() };
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(material);
    let place = Transform::from_xyz(0.0, 0.0, -1.0).with_scale(Vec3::new(1.2, 1.2, 0.4));
    for _ in 0..10 {
        app.update();
    }
    let hole = app.world.spawn((Decal::new(material), place)).id();
    for _ in 0..3 {
        app.update();
    }
    let shown = display(&mut app);
    app.world.despawn(hole);
    for _ in 0..3 {
        app.update();
    }
    let gone = display(&mut app);
    app.world.resource_mut::<RenderSettings>().aa = AntiAliasing::None;
    app.update();
    let wall = display(&mut app);
    app.world.spawn((Decal::new(material), place));
    app.update();
    let decal = display(&mut app);

    // The decal's inside: flat in the un-anti-aliased image, and darker than the wall.
    let inside: Vec<usize> = (0..(SIZE.0 * SIZE.1) as usize)
        .filter(|&i| flat_around(&decal, i) && i32::from(decal[i * 4]) + 20 < i32::from(wall[i * 4]))
        .collect();
    assert!(inside.len() > 200, "the decal covers part of the view: {}", inside.len());
    let contrast = |image: &[u8]| inside.iter().map(|&i| wall[i * 4] as f32 - image[i * 4] as f32).sum::<f32>();
    let reached = contrast(&shown) / contrast(&decal);
    let (ghost, n) = largest_difference(&gone, &wall, |i| flat_around(&wall, i));
    eprintln!(
        "3 frames after the spawn the decal has {:.1} % of its contrast; 3 frames after the despawn the largest difference is {ghost:.4} ({n} px)",
        reached * 100.0
    );
    assert!(reached >= 0.95, "a new decal is sharp within 3 frames: {reached}");
    assert!(ghost <= 0.02, "a despawned decal leaves no ghost: {ghost}");
}

/// The contrast (standard deviation of the red channel, in [0, 1]) of the middle half of an
/// RGBA8 image.
fn contrast(image: &[u8]) -> f32 {
    let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
    let values: Vec<f32> =
        (h / 4..3 * h / 4).flat_map(|y| (w / 4..3 * w / 4).map(move |x| image[(y * w + x) * 4] as f32 / 255.0)).collect();
    let mean = values.iter().sum::<f32>() / values.len() as f32;
    (values.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / values.len() as f32).sqrt()
}

/// A fine checkerboard (one texel a check, about 1.6 pixels) on the wall keeps most of its
/// contrast while the camera pans across it under TAA: the history is resampled with
/// Catmull-Rom every frame, where a bilinear history blurs a little more at each step (the
/// smearing of Bevy #10183), and motion raises the current frame's share. The still image under
/// TAA is the yardstick (jitter averages checks near the pixel size by design).
#[test]
fn a_fine_texture_stays_sharp_while_the_camera_pans_under_taa() {
    let mut app = wall_app(PipelineKind::Deferred);
    let n = 128usize;
    let texels: Vec<u8> =
        (0..n * n).flat_map(|i| if (i % n + i / n).is_multiple_of(2) { [230, 230, 230, 255] } else { [25, 25, 25, 255] }).collect();
    let image = Image::from_rgba8(n as u32, n as u32, texels, ColorSpace::Srgb).expect("a checkerboard");
    let image = app.world.resource_mut::<Assets<Image>>().add(image);
    let checks = Material { base_color_texture: Some(image), ..Material::from_color(Vec4::ONE, 0.0, 0.9) };
    let checks = app.world.resource_mut::<Assets<Material>>().add(checks);
    let wall = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0 / 12.0));
    let facing_camera = Transform::from_xyz(0.0, 0.0, -0.9).with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    app.world.spawn((MeshInstance { mesh: wall, material: checks }, facing_camera));
    let camera_at = |app: &mut App, x: f32| {
        let mut q = app.world.query_filtered::<&mut Transform, With<Camera>>();
        *q.single_mut(&mut app.world).unwrap() = Transform::from_xyz(x, 0.0, 4.0).looking_at(Vec3::new(x, 0.0, 0.0), Vec3::Y);
    };
    for _ in 0..24 {
        app.update();
    }
    let still = contrast(&display(&mut app));
    // About a fifth of a pixel a frame.
    for i in 1..=24 {
        camera_at(&mut app, 0.011 * i as f32);
        app.update();
    }
    let panning = contrast(&display(&mut app));
    app.world.resource_mut::<RenderSettings>().aa = AntiAliasing::None;
    app.update();
    let plain = contrast(&display(&mut app));
    eprintln!(
        "checkerboard contrast: no anti-aliasing {plain:.4}, TAA still {still:.4}, TAA panning {panning:.4} ({:.0} % of still)",
        panning / still * 100.0
    );
    // Measured 71 %; a bilinear history keeps 49 %, a constant blend weight 51 %.
    assert!(panning >= 0.6 * still, "panning keeps the texture's contrast: {panning} against {still} still");
}
