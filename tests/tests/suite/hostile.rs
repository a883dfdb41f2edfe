//! Hostile input from gameplay code: NaN, infinite, zero, negative and out-of-range values in
//! lights, meshes, mesh instances, decals, images and the camera, and a zero-size render target.
//! Nothing may panic or produce a validation error; each bad entity or asset is skipped (or
//! clamped) with exactly one warning naming it, however many frames it stays bad; and the valid
//! scene around it renders exactly as it does without it.

use engine::environment::{Environment, EnvironmentSource, HdrImage, Projection};
use engine::image::{ColorSpace, Image, TexelFormat};
use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial, DecalUv};
use plugins::{RenderMirror, RenderSettings};
use render::settings::{DecalMethod, PipelineKind};
use tests::{TopDownView, WarningLog, assert_no_validation_errors, error_stats, gpu_app, renderer};

const SIZE: (u32, u32) = (64, 48);

/// A grey plane lit by one point light, seen from above.
fn lit_plane_app() -> App {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { pipeline: PipelineKind::Deferred, ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.5, 0.5, 0.5, 1.0), 0.0, 0.8));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    app.world.spawn((PointLight { intensity: 20.0, ..Default::default() }, Transform::from_xyz(0.5, 2.0, 0.0)));
    TopDownView::new(4.0, SIZE).spawn(&mut app.world);
    app
}

fn hdr(app: &mut App) -> Vec<[f32; 4]> {
    renderer(app).finish();
    let image = renderer(app).read_hdr().expect("read back the HDR target");
    assert!(image.iter().flatten().all(|c| c.is_finite()), "every pixel is finite");
    image
}

fn assert_same_image(a: &[[f32; 4]], b: &[[f32; 4]], what: &str) {
    let (mean, p99) = error_stats(a, b, |_| true);
    assert!(mean < 1e-5 && p99 < 1e-4, "{what}: the valid scene renders as without the hostile input (mean {mean}, p99 {p99})");
}

/// Marks every listed entity's transform changed, so extraction looks at it again this frame.
fn touch(app: &mut App, entities: &[Entity]) {
    for &e in entities {
        if let Some(mut t) = app.world.get_mut::<Transform>(e) {
            t.set_changed();
        }
    }
}

fn zero_rotation() -> Quat {
    Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)
}

#[test]
fn hostile_entities_and_assets_are_skipped_with_one_warning_each_and_the_rest_renders() {
    let mut app = lit_plane_app();
    let log = WarningLog::capture(&mut app);
    app.update();
    let reference = hdr(&mut app);
    assert!(log.warnings().is_empty(), "the valid scene warns about nothing: {:?}", log.warnings());

    let nan = f32::NAN;
    let at = |x: f32| Transform::from_xyz(x, 1.0, 0.0);
    let mut bad = Vec::new(); // entities that must be warned about exactly once
    let mut fine = Vec::new(); // entities that must not be warned about

    // Lights. A light with zero colour still goes through every culling and shading path.
    let point = |intensity: f32, range: Option<f32>| PointLight { intensity, range, ..Default::default() };
    for light in [point(nan, None), point(-5.0, None), point(f32::INFINITY, None), point(5.0, Some(0.0)), point(5.0, Some(nan))] {
        bad.push(app.world.spawn((light, at(0.0))).id());
    }
    bad.push(app.world.spawn((point(5.0, None), Transform::from_xyz(nan, 1.0, 0.0))).id());
    bad.push(app.world.spawn((SpotLight { inner_angle: nan, ..Default::default() }, at(0.0))).id());
    bad.push(app.world.spawn((DirectionalLight { illuminance: nan, ..Default::default() }, Transform::default())).id());
    // Clamped rather than skipped: warned once, drawn (with zero colour, so the image is unchanged).
    let clamped = SpotLight { color: Vec3::ZERO, inner_angle: 2.0, outer_angle: 5.0, ..Default::default() };
    bad.push(app.world.spawn((clamped, at(0.0))).id());
    let clamped_spot = *bad.last().unwrap();
    // Valid oddities: an unbounded light of zero intensity, a tiny cone.
    fine.push(app.world.spawn((point(0.0, Some(f32::INFINITY)), at(0.0))).id());
    fine.push(app.world.spawn((SpotLight { color: Vec3::ZERO, outer_angle: 1e-3, ..Default::default() }, at(0.0))).id());
    // The zero quaternion makes an identity rotation in glam: valid, shining along −Z.
    fine.push(app.world.spawn((SpotLight { color: Vec3::ZERO, ..Default::default() }, at(0.0).with_rotation(zero_rotation()))).id());

    // Meshes (assets) and their instances.
    let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
    let tri = |p: [[f32; 3]; 3], indices: Vec<u32>| Mesh {
        positions: p.to_vec(),
        normals: vec![[0.0, 1.0, 0.0]; 3],
        uvs: vec![[0.0; 2]; 3],
        tangents: vec![[1.0, 0.0, 0.0, 1.0]; 3],
        indices,
        ..Default::default()
    };
    let good = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
    let empty = meshes.add(Mesh::default());
    let all_nan = meshes.add(tri([[nan; 3]; 3], vec![0, 1, 2]));
    let out_of_range = meshes.add(tri(good, vec![0, 1, 7]));
    let mut partly = tri(good, vec![0, 1, 2, 0, 1, 9, 0]);
    partly.normals[1] = [nan, 0.0, 0.0];
    let partly_broken = meshes.add(partly);
    let degenerate = meshes.add(tri([[0.2, 0.1, 0.2]; 3], vec![0, 1, 2]));
    let cube = meshes.add(shapes::cuboid(Vec3::splat(0.3), 1.0));
    let bad_meshes = [empty, all_nan, out_of_range, partly_broken];
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::ONE, 0.0, 0.5));
    let instance = |mesh| MeshInstance { mesh, material: grey };
    for mesh in [empty, all_nan, out_of_range] {
        bad.push(app.world.spawn((instance(mesh), Transform::default())).id());
    }
    bad.push(app.world.spawn((instance(cube), Transform::from_xyz(0.0, 0.5, nan))).id());
    bad.push(app.world.spawn((instance(cube), Transform::from_xyz(0.0, 0.5, 0.0).with_scale(Vec3::ZERO))).id());
    // Drawn, but far outside the view: the repaired mesh, a non-unit and a zero rotation.
    fine.push(app.world.spawn((instance(cube), Transform::from_xyz(100.0, 0.5, 0.0).with_rotation(zero_rotation()))).id());
    fine.push(app.world.spawn((instance(partly_broken), Transform::from_xyz(100.0, 0.0, 0.0))).id());
    fine.push(
        app.world.spawn((instance(cube), Transform::from_xyz(100.0, 0.0, 0.0).with_rotation(Quat::from_xyzw(0.0, 0.0, 0.0, 3.0)))).id(),
    );
    // A degenerate (zero-area) triangle in view is valid and draws nothing.
    fine.push(app.world.spawn((instance(degenerate), Transform::default())).id());

    // Decals: bright red, over the visible plane, so a bad one that lands would show.
    let red = app
        .world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(Vec4::new(1.0, 0.0, 0.0, 1.0)), ..Default::default() });
    let on_ground = Transform::from_xyz(0.0, 0.0, 0.0)
        .with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(2.0, 2.0, 1.0));
    let decal = |f: &dyn Fn(&mut Decal)| {
        let mut d = Decal::new(red);
        f(&mut d);
        d
    };
    for d in [
        decal(&|d| d.weight = nan),
        decal(&|d| d.weight = -1.0),
        decal(&|d| d.weight = f32::INFINITY),
        decal(&|d| d.weight = 0.0),
        decal(&|d| d.channel = 9),
        decal(&|d| d.opacity = nan),
        decal(&|d| d.uv = DecalUv::Rect { min: Vec2::splat(nan), max: Vec2::ONE }),
    ] {
        bad.push(app.world.spawn((d, on_ground)).id());
    }
    for t in [on_ground.with_scale(Vec3::new(2.0, 0.0, 1.0)), on_ground.with_scale(Vec3::splat(1e30)), Transform::from_xyz(nan, 0.0, 0.0)] {
        bad.push(app.world.spawn((Decal::new(red), t)).id());
    }
    // Non-unit and zero rotations are valid transforms (scaled, or the identity); drawn far away.
    fine.push(app.world.spawn((Decal::new(red), Transform::from_xyz(100.0, 0.0, 0.0).with_rotation(zero_rotation()))).id());
    fine.push(
        app.world.spawn((Decal::new(red), Transform::from_xyz(100.0, 0.0, 0.0).with_rotation(Quat::from_xyzw(0.0, 0.0, 0.0, 2.0)))).id(),
    );

    // Images built field by field (decoded images are checked by the loader).
    let mut images = app.world.resource_mut::<Assets<Image>>();
    let zero = images.add(Image { width: 0, height: 0, color_space: ColorSpace::Srgb, format: TexelFormat::Rgba8, mips: vec![] });
    let short =
        images.add(Image { width: 4, height: 4, color_space: ColorSpace::Srgb, format: TexelFormat::Rgba8, mips: vec![vec![255; 3]] });
    let absurd =
        images.add(Image { width: 1 << 30, height: 1, color_space: ColorSpace::Srgb, format: TexelFormat::Rgba8, mips: vec![vec![0; 4]] });
    // Block-compressed ones: an 8×8 BC1 level needs four blocks, and a 4×4 image has three levels.
    let block = [0xFF, 0x07, 0xFF, 0x07, 0, 0, 0, 0];
    let bc1 = |w, h, mips| Image { width: w, height: h, color_space: ColorSpace::Srgb, format: TexelFormat::Bc1, mips };
    let short_blocks = images.add(bc1(8, 8, vec![block.to_vec()]));
    let deep = images.add(bc1(4, 4, vec![block.to_vec(); 4]));
    let compressed = images.add(bc1(8, 8, vec![block.repeat(4), block.to_vec(), block.to_vec(), block.to_vec()]));
    let bad_images = [zero, short, absurd, short_blocks, deep];
    let textured = Material { base_color_texture: Some(zero), ..Material::from_color(Vec4::ONE, 0.0, 0.5) };
    let textured = app.world.resource_mut::<Assets<Material>>().add(textured);
    fine.push(app.world.spawn((MeshInstance { mesh: cube, material: textured }, Transform::from_xyz(100.0, 0.0, 0.0))).id());
    let bc_textured = Material { base_color_texture: Some(compressed), ..Material::from_color(Vec4::ONE, 0.0, 0.5) };
    let bc_textured = app.world.resource_mut::<Assets<Material>>().add(bc_textured);
    fine.push(app.world.spawn((MeshInstance { mesh: cube, material: bc_textured }, Transform::from_xyz(100.0, 2.0, 0.0))).id());

    // Several frames in which every hostile entity changes again: still one warning each.
    for _ in 0..3 {
        touch(&mut app, &bad);
        touch(&mut app, &fine);
        app.update();
    }
    assert_no_validation_errors(&mut app);
    for &e in &bad {
        let warnings = log.about(e);
        assert_eq!(warnings.len(), 1, "entity {e:?} is warned about exactly once: {warnings:?} (all: {:?})", log.warnings());
    }
    for &e in &fine {
        assert!(log.about(e).is_empty(), "valid entity {e:?} is not warned about: {:?}", log.about(e));
    }
    for handle in bad_meshes {
        assert_eq!(log.about(handle).len(), 1, "mesh {handle:?} is warned about once: {:?}", log.warnings());
    }
    for handle in bad_images {
        assert_eq!(log.about(handle).len(), 1, "image {handle:?} is warned about once: {:?}", log.warnings());
    }
    for mesh in [degenerate, cube] {
        assert!(log.about(mesh).is_empty(), "valid mesh {mesh:?} is not warned about");
    }
    let mirror = &app.world.resource::<RenderMirror>().0;
    assert!(mirror.lights.len() >= 4, "the valid, the clamped and the odd-but-valid lights are drawn");
    let slots = app.world.resource::<plugins::MirrorSlots>();
    assert!(slots.light(clamped_spot).is_some(), "a clamped spot light is drawn");
    assert!(slots.light(bad[0]).is_none(), "a NaN light has no slot");
    assert_same_image(&hdr(&mut app), &reference, "deferred");

    // Every pipeline and decal method draws the same scene without error or NaN.
    for pipeline in PipelineKind::ALL {
        for method in DecalMethod::ALL {
            {
                let mut s = app.world.resource_mut::<RenderSettings>();
                s.pipeline = pipeline;
                s.decal_method = method;
            }
            app.update();
            hdr(&mut app);
        }
    }
    assert_no_validation_errors(&mut app);
    assert!(log.about(bad[0]).len() == 1, "still one warning after switching pipelines");
}

/// Issue 55: an environment far beyond what half floats hold (and NaN and infinite texels,
/// which only a map built in code can have: the loaders clamp them), at an intensity of 1e30,
/// and a light of 1e38 leave every pipeline's picture finite, the tone mapper never sees a
/// value that is not finite (the debug builds' check), and the lit plane is not black.
#[test]
fn a_blinding_environment_and_light_leave_every_pipeline_finite() {
    let mut app = lit_plane_app();
    let texels: std::sync::Arc<[[f32; 3]]> = (0..32 * 16)
        .map(|i| match i % 4 {
            0 => [1e30; 3],
            1 => [f32::INFINITY, 1.0, 1.0],
            2 => [f32::NAN, 0.5, 0.5],
            _ => [0.5; 3],
        })
        .collect();
    let map = HdrImage { width: 32, height: 16, texels, projection: Projection::Equirectangular };
    app.insert_resource(Environment { source: EnvironmentSource::Map(map), intensity: 1e30, rotation: 0.0 });
    app.world.spawn((PointLight { intensity: 1e38, ..Default::default() }, Transform::from_xyz(-0.5, 1.5, 0.5)));
    for pipeline in PipelineKind::ALL {
        app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
        app.update();
        app.update();
        hdr(&mut app);
        let display = renderer(&mut app).read_display().expect("read back the display");
        let lit = display.chunks_exact(4).filter(|p| p[..3].iter().any(|&c| c > 0)).count();
        assert!(lit > display.len() / 8, "{pipeline:?}: the picture is not black ({lit} pixels lit)");
    }
    // The last frames' counts come back two frames later.
    for _ in 0..3 {
        app.update();
    }
    let check = renderer(&mut app).display_check().expect("tests run debug builds, which check the tone mapper's input");
    assert!(check.frames >= 8, "{check:?}");
    assert_eq!(check.non_finite_pixels, 0, "no pass wrote a value that is not finite");
    assert_no_validation_errors(&mut app);
}

#[test]
fn a_broken_camera_or_render_size_keeps_the_scene_rendering_with_one_warning() {
    let mut app = lit_plane_app();
    let log = WarningLog::capture(&mut app);
    app.update();
    let reference = hdr(&mut app);
    let camera = app.world.query_filtered::<Entity, With<Camera>>().single(&app.world).unwrap();
    let camera_warnings = |log: &WarningLog| log.warnings().into_iter().filter(|w| w.message.contains("camera")).count();

    // A NaN position keeps the last good view.
    let good = *app.world.get::<Transform>(camera).unwrap();
    app.world.get_mut::<Transform>(camera).unwrap().translation.x = f32::NAN;
    for _ in 0..3 {
        touch(&mut app, &[camera]);
        app.update();
    }
    assert_eq!(camera_warnings(&log), 1, "{:?}", log.warnings());
    assert_same_image(&hdr(&mut app), &reference, "NaN camera position");
    *app.world.get_mut::<Transform>(camera).unwrap() = good;

    // A zero or NaN field of view renders with a default one.
    for fov in [0.0, f32::NAN] {
        app.world.get_mut::<Camera>(camera).unwrap().fov_y = fov;
        for _ in 0..2 {
            app.update();
        }
        hdr(&mut app);
    }
    assert_eq!(camera_warnings(&log), 2, "one more warning for the lens, however it stays bad: {:?}", log.warnings());
    app.world.get_mut::<Camera>(camera).unwrap().fov_y = TopDownView::new(4.0, SIZE).camera.fov_y;
    app.update();
    assert_same_image(&hdr(&mut app), &reference, "camera restored");

    // A zero-size render target renders nothing, says so once, and recovers.
    for size in [(0, 0), (0, 48), (64, 0)] {
        app.world.resource_mut::<RenderSettings>().size = size;
        for _ in 0..3 {
            app.update();
        }
    }
    let size_warnings = log.warnings().into_iter().filter(|w| w.message.contains("render size")).count();
    assert_eq!(size_warnings, 3, "one warning per refused size: {:?}", log.warnings());
    app.world.resource_mut::<RenderSettings>().size = (1, 1);
    app.update();
    assert_eq!(renderer(&mut app).size(), (1, 1));
    hdr(&mut app);
    app.world.resource_mut::<RenderSettings>().size = SIZE;
    app.update();
    assert_same_image(&hdr(&mut app), &reference, "back at the original size");
    assert_no_validation_errors(&mut app);
}
