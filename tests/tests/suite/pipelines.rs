//! The three pipelines (forward, deferred, visibility buffer) and the two decal methods (ray
//! query, deferred decals) against each other on lavapipe.
//!
//! Tolerances, on linear radiance read back from the HDR target (fp16):
//! - same scene, ray-query decals, deferred vs forward: mean absolute error ≤ 0.002 and 99th
//!   percentile ≤ 0.012 (measured: 0.00078 and 0.0027). The G-buffer quantises albedo to 8-bit sRGB, normals to 10 bits and
//!   roughness/metallic to 8 bits, and the lighting pass takes decal texture gradients from depth
//!   differences rather than quad derivatives.
//! - visibility buffer vs forward: mean ≤ 0.002, 99th percentile ≤ 0.012 (measured: 0.00069 and
//!   0.0053): analytic gradients pick
//!   slightly different mip levels than the hardware's 2×2 quads, and attributes are
//!   interpolated from the ray hit rather than by the rasteriser.
//! - depth: bit-identical (every pipeline's depth comes from the same invariant vertex shader).
//! - ray-traced decal methods on one pipeline, albedo and roughness/metallic views (and normals in
//!   the deferred pipeline): the two decal passes (ray-tracing pipeline, ray-query compute) write
//!   the same decal buffer from the same inputs, and so do clustered decals (the same decal
//!   evaluation over the pixel's cluster list instead of the boxes a ray found): max difference
//!   ≤ 0.002 (measured: 0, the images are identical). In-shader ray queries against the ray-tracing-pipeline pass: mean ≤ 0.002
//!   and 99th percentile ≤ 0.012, the bounds used between pipelines (measured: mean ≤ 0.00006,
//!   99th percentile ≤ 0.0013): the decal pass takes texture gradients from neighbouring depths
//!   where the forward shader has the rasteriser's quad derivatives, and the buffer holds fp16.

use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{RenderSettings, RenderStats};
use render::{DebugView, DecalMethod, PipelineKind};
use tests::{TopDownView, assert_no_validation_errors, error_stats, gpu_app, renderer};

const SIZE: (u32, u32) = (160, 120);

/// The courtyard (textures, normal maps, sun, point and spot lights), 300 overlapping decals,
/// and an alpha-masked lattice in front of the camera.
fn courtyard_app() -> App {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings::default());
    let info = sandbox::scene::spawn_courtyard(&mut app.world);
    let materials = sandbox::decal_textures::add_builtin_materials(&mut app.world);
    assert_eq!(sandbox::scatter::scatter_decals(&mut app.world, 300, 3, &materials), 300);
    // A lattice: 8×8 texels, alternate ones transparent, masked at 0.5.
    let lattice: Vec<u8> = (0..64).flat_map(|i| if (i % 8 + i / 8) % 2 == 0 { [200, 60, 40, 255] } else { [0, 0, 0, 0] }).collect();
    let image = app.world.resource_mut::<Assets<Image>>().add(Image::from_rgba8(8, 8, lattice, ColorSpace::Srgb).unwrap());
    let material = app.world.resource_mut::<Assets<Material>>().add(Material {
        base_color_texture: Some(image),
        alpha_mode: AlphaMode::Mask(0.5),
        double_sided: true,
        ..Default::default()
    });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(1.2, 1.2, 1, 1.0));
    let camera = *app.world.get::<Transform>(info.camera).unwrap();
    let in_front = camera.translation + camera.forward() * 2.5 + Vec3::new(0.0, -0.3, 0.0);
    app.world.spawn((
        MeshInstance { mesh, material },
        Transform::from_translation(in_front).looking_at(camera.translation, Vec3::Y).with_rotation(
            Transform::from_translation(in_front).looking_at(camera.translation, Vec3::Y).rotation
                * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        ),
    ));
    app
}

fn render_with(app: &mut App, pipeline: PipelineKind, method: DecalMethod, view: DebugView) -> (Vec<[f32; 4]>, Vec<f32>) {
    {
        let mut s = app.world.resource_mut::<RenderSettings>();
        s.pipeline = pipeline;
        s.decal_method = method;
        s.debug_view = view;
    }
    app.update();
    let r = renderer(app);
    (r.read_hdr().unwrap(), r.read_depth().unwrap())
}

#[test]
fn all_pipelines_render_the_same_scene_alike_and_the_same_depth() {
    let mut app = courtyard_app();
    let (forward, forward_depth) = render_with(&mut app, PipelineKind::Forward, DecalMethod::RayQuery, DebugView::Lit);
    let covered = |i: usize| forward_depth[i] > 0.0;
    let pixels = (SIZE.0 * SIZE.1) as usize;
    let covered_count = forward_depth.iter().filter(|d| **d > 0.0).count();
    assert!(covered_count > pixels / 2, "geometry covers more than half the image: {covered_count} of {pixels} pixels");
    // The sky check below compares only pixels no geometry covers; without any (a camera buried
    // in a wall or looking at the floor) it would pass vacuously.
    let sky_count = pixels - covered_count;
    eprintln!("sky: {sky_count} of {pixels} pixels");
    assert!(
        sky_count >= pixels / 20,
        "the courtyard camera must see some sky for the clear-colour check to mean anything: \
         only {sky_count} of {pixels} pixels are uncovered (is the camera broken?)"
    );
    for pipeline in [PipelineKind::Deferred, PipelineKind::VisBuffer, PipelineKind::ForwardPlus] {
        let (image, depth) = render_with(&mut app, pipeline, DecalMethod::RayQuery, DebugView::Lit);
        assert_no_validation_errors(&mut app);
        assert!(depth == forward_depth, "{pipeline:?}: depth is bit-identical to forward");
        let (mean, p99) = error_stats(&image, &forward, covered);
        eprintln!("{pipeline:?} vs forward: mean {mean:.5}, p99 {p99:.5}");
        assert!(mean <= 0.002 && p99 <= 0.012, "{pipeline:?} vs forward: mean {mean}, p99 {p99}");
        let sky = |i: usize| !covered(i);
        let (sky_mean, _) = error_stats(&image, &forward, sky);
        assert!(sky_mean < 1e-4, "the sky is the clear colour in every pipeline");
    }
    assert_eq!(app.world.resource::<RenderStats>().last.decals, 300);
}

#[test]
fn lighting_in_compute_and_in_full_screen_fragment_passes_gives_the_same_image() {
    let mut app = courtyard_app();
    for pipeline in [PipelineKind::Deferred, PipelineKind::VisBuffer] {
        for method in [DecalMethod::RayQuery, DecalMethod::RayPipeline] {
            let mut images = Vec::new();
            for compute in [true, false] {
                app.world.resource_mut::<RenderSettings>().compute_shading = compute;
                let (image, _) = render_with(&mut app, pipeline, method, DebugView::Lit);
                assert_no_validation_errors(&mut app);
                images.push(image);
            }
            assert!(images[0] == images[1], "{pipeline:?}, {method:?}: compute and fragment shading agree to the bit");
        }
    }
}

#[test]
fn alpha_masked_holes_stay_open_in_every_pipeline() {
    // Seen straight on, the lattice's transparent texels must show what is behind them.
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { ambient: Vec3::ONE, clear_color: [0.0, 0.0, 1.0, 1.0], ..Default::default() });
    let lattice: Vec<u8> = (0..16).flat_map(|i| if (i % 4 + i / 4) % 2 == 0 { [255, 0, 0, 255] } else { [0, 0, 0, 0] }).collect();
    let image = app.world.resource_mut::<Assets<Image>>().add(Image::from_rgba8(4, 4, lattice, ColorSpace::Linear).unwrap());
    let material = app.world.resource_mut::<Assets<Material>>().add(Material {
        base_color_texture: Some(image),
        alpha_mode: AlphaMode::Mask(0.5),
        ..Default::default()
    });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(4.0, 4.0, 1, 1.0));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    TopDownView::new(3.0, SIZE).spawn(&mut app.world);
    let mut images = Vec::new();
    for pipeline in PipelineKind::ALL {
        let (hdr, depth) = render_with(&mut app, pipeline, DecalMethod::Off, DebugView::Albedo);
        assert_no_validation_errors(&mut app);
        let holes = depth.iter().filter(|d| **d == 0.0).count();
        let solid = depth.iter().filter(|d| **d > 0.0).count();
        assert!(holes > 3000 && solid > 3000, "{pipeline:?}: holes {holes}, solid {solid}");
        // Every pixel is either the red lattice or the blue sky behind it.
        for (i, px) in hdr.iter().enumerate() {
            if depth[i] == 0.0 {
                assert!(px[2] > 0.99 && px[0] < 0.01, "{pipeline:?}: a hole shows the background");
            }
        }
        images.push(depth);
    }
    assert!(images.windows(2).all(|w| w[0] == w[1]), "the same holes in every pipeline");
}

#[test]
fn ray_traced_decal_methods_give_the_same_image_in_every_pipeline() {
    // The courtyard's 300 textured, normal-mapped decals, in each pipeline: in-shader ray queries,
    // the ray-query compute decal pass, the ray-tracing-pipeline decal pass (lavapipe offers all
    // three on the ray-query tier) and clustered decals (which need no ray tracing: a decal pass,
    // and in forward and Forward+ also the lists walked in the shading, with the shader's own
    // derivatives, as in-shader ray queries have).
    // The normal view too in the deferred pipeline, where every method builds decal normals on
    // the same G-buffer normal (the forward and visibility-buffer decal passes build them on the
    // vertex normal: shaders/include/decal_surface.glsl).
    let mut app = courtyard_app();
    for pipeline in PipelineKind::ALL {
        let views: &[DebugView] = match pipeline {
            PipelineKind::Deferred => &[DebugView::Albedo, DebugView::RoughnessMetallic, DebugView::Normal],
            _ => &[DebugView::Albedo, DebugView::RoughnessMetallic],
        };
        for &view in views {
            let (in_shader, depth) = render_with(&mut app, pipeline, DecalMethod::RayQuery, view);
            let (compute, _) = render_with(&mut app, pipeline, DecalMethod::RayQueryCompute, view);
            let (ray_pipeline, _) = render_with(&mut app, pipeline, DecalMethod::RayPipeline, view);
            let (clustered, _) = render_with(&mut app, pipeline, DecalMethod::Clustered, view);
            let max_diff = |x: &[[f32; 4]], y: &[[f32; 4]]| {
                x.iter().zip(y).flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs())).fold(0.0f32, f32::max)
            };
            if pipeline.is_forward() {
                app.world.resource_mut::<RenderSettings>().decals_in_forward_shading = true;
                let (in_shading, _) = render_with(&mut app, pipeline, DecalMethod::Clustered, view);
                for _ in 0..3 {
                    app.update(); // the timestamps come back a few frames later
                }
                app.world.resource_mut::<RenderSettings>().decals_in_forward_shading = false;
                let stats = app.world.resource::<plugins::RenderStats>();
                let frame = stats.completed.back().expect("frames with GPU times");
                assert_eq!((frame.pipeline, frame.decal_method), (pipeline, DecalMethod::Clustered));
                assert!(frame.gpu.get("decal_pass_clustered").is_none(), "{pipeline:?}: no decal pass when the shading walks the lists");
                assert!(frame.gpu.get("decal_clusters_fill").is_some(), "{pipeline:?}: the binning still runs");
                let max = max_diff(&in_shading, &in_shader);
                eprintln!("{pipeline:?} {view:?}: clustered in the shading vs in-shader ray queries max {max:.5}");
                assert!(max <= 0.002, "{pipeline:?} {view:?}: clustered decals walked in the shading differ by {max}");
            }
            assert_no_validation_errors(&mut app);
            let covered = |i: usize| depth[i] > 0.0;
            let max = max_diff(&compute, &ray_pipeline);
            let max_clustered = max_diff(&clustered, &ray_pipeline);
            let (mean, p99) = error_stats(&ray_pipeline, &in_shader, covered);
            let (clustered_mean, clustered_p99) = error_stats(&clustered, &in_shader, covered);
            assert!(
                clustered_mean <= 0.002 && clustered_p99 <= 0.012,
                "{pipeline:?} {view:?}: clustered vs in-shader ray queries: mean {clustered_mean}, p99 {clustered_p99}"
            );
            eprintln!(
                "{pipeline:?} {view:?}: compute vs ray pipeline max {max:.5}; clustered vs ray pipeline max {max_clustered:.5}; \
                 ray pipeline vs in-shader mean {mean:.5} p99 {p99:.5}"
            );
            assert!(max <= 0.002, "{pipeline:?} {view:?}: the two ray-traced decal passes differ by {max}");
            assert!(max_clustered <= 0.002, "{pipeline:?} {view:?}: clustered and ray-traced decal passes differ by {max_clustered}");
            assert!(mean <= 0.002 && p99 <= 0.012, "{pipeline:?} {view:?}: ray pipeline vs in-shader ray queries: mean {mean}, p99 {p99}");
            let (plain, _) = render_with(&mut app, pipeline, DecalMethod::Off, view);
            let decaled = (0..plain.len()).filter(|&i| (0..3).any(|c| (plain[i][c] - ray_pipeline[i][c]).abs() > 0.02)).count();
            // Every built-in decal blends albedo; a few set roughness or metallic, and their
            // normal maps are gentle (a change over 0.02 on few pixels).
            let least = if view == DebugView::Albedo { plain.len() / 50 } else { 20 };
            assert!(decaled > least, "{pipeline:?} {view:?}: the decals show ({decaled} pixels changed)");
        }
    }
}

fn decal_plane_app() -> (App, TopDownView) {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { debug_view: DebugView::Albedo, ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.5, 0.5, 0.5, 1.0), 0.0, 0.8));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    let view = TopDownView::new(4.0, SIZE);
    view.spawn(&mut app.world);
    (app, view)
}

fn flat_decal(app: &mut App, color: Vec3, alpha: f32, centre: Vec3, channel: u8, weight: f32) {
    let material = app
        .world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(color.extend(alpha)), ..Default::default() });
    let mut decal = Decal::new(material);
    decal.channel = channel;
    decal.weight = weight;
    let t = Transform::from_translation(centre)
        .with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(1.6, 1.6, 1.0));
    app.world.spawn((decal, t));
}

#[test]
fn ray_query_and_deferred_decals_agree_where_they_must_and_differ_where_blending_does() {
    let (mut app, view) = decal_plane_app();
    let bg = Vec3::splat(0.5);
    let (red, green, blue, yellow) =
        (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 0.0));
    let a = 0.6;
    // Left: red (weight 1) and green (weight 1.5), nearly opaque, overlap in one channel.
    let a2 = 0.9;
    flat_decal(&mut app, red, a2, Vec3::new(-1.2, 0.0, 0.0), 0, 1.0);
    flat_decal(&mut app, green, a2, Vec3::new(-0.6, 0.0, 0.0), 0, 1.5);
    // Right: blue in channel 0 under yellow in channel 1.
    flat_decal(&mut app, blue, a, Vec3::new(1.2, 0.0, 0.0), 0, 1.0);
    flat_decal(&mut app, yellow, a, Vec3::new(1.2, 0.0, 0.6), 1, 1.0);

    let (rq, _) = render_with(&mut app, PipelineKind::Deferred, DecalMethod::RayQuery, DebugView::Albedo);
    let (dd, _) = render_with(&mut app, PipelineKind::Deferred, DecalMethod::DeferredDecals, DebugView::Albedo);
    assert_no_validation_errors(&mut app);
    let at = |img: &[[f32; 4]], p: Vec3| {
        let (px, py) = view.pixel_of(p);
        Vec3::from_slice(&img[(py * SIZE.0 + px) as usize][..3])
    };
    let over = |c: Vec3, under: Vec3| c * a + under * (1.0 - a);
    // The G-buffer holds albedo in 8-bit sRGB: about 1 % steps in the darks.
    let close = |x: Vec3, y: Vec3| (x - y).abs().max_element() < 0.012;

    // A single decal: both methods give plain alpha blending.
    let lone = Vec3::new(-1.7, 0.0, 0.0);
    let expected = red * a2 + bg * (1.0 - a2);
    assert!(close(at(&rq, lone), expected) && close(at(&dd, lone), expected), "{} {}", at(&rq, lone), at(&dd, lone));
    // Different channels: both alpha-blend channel 1 over channel 0.
    let stacked = Vec3::new(1.2, 0.0, 0.3);
    let expected = over(yellow, over(blue, bg));
    assert!(
        close(at(&rq, stacked), expected) && close(at(&dd, stacked), expected),
        "{} {} {}",
        at(&rq, stacked),
        at(&dd, stacked),
        expected
    );

    // One channel, two weights: ray-query decals take the weighted average (order-independent,
    // seed §4.3.1); deferred decals draw the heavier one last, on top (sorted, §5.2.2).
    let overlap = Vec3::new(-0.9, 0.0, 0.0);
    let vis = (1.0 - a2) * (1.0 - a2);
    let oit = (red * a2 * 1.0 + green * a2 * 1.5) / (a2 * 1.0 + a2 * 1.5) * (1.0 - vis) + bg * vis;
    let on_top = |c: Vec3, under: Vec3| c * a2 + under * (1.0 - a2);
    let sorted = on_top(green, on_top(red, bg));
    assert!(close(at(&rq, overlap), oit), "ray query {} vs OIT {oit}", at(&rq, overlap));
    assert!(close(at(&dd, overlap), sorted), "deferred {} vs sorted {sorted}", at(&dd, overlap));
    assert!((oit - sorted).abs().max_element() > 0.2, "the two blends are told apart");
}

#[test]
fn switching_pipelines_every_frame_leaks_nothing() {
    let (mut app, _) = decal_plane_app();
    for i in 0..20 {
        flat_decal(&mut app, Vec3::new(0.2, 0.4, 0.8), 0.7, Vec3::new(-2.0 + i as f32 * 0.2, 0.0, 0.0), (i % 4) as u8, 1.0);
    }
    let combos: Vec<(PipelineKind, DecalMethod)> =
        PipelineKind::ALL.into_iter().flat_map(|p| DecalMethod::ALL.into_iter().map(move |m| (p, m))).collect();
    let mut level = None;
    for frame in 0..300 {
        let (pipeline, method) = combos[frame % combos.len()];
        {
            let mut s = app.world.resource_mut::<RenderSettings>();
            s.pipeline = pipeline;
            s.decal_method = method;
            s.debug_view = DebugView::Lit;
        }
        app.update();
        if frame == 2 * combos.len() {
            render::Renderer::finish(renderer(&mut app));
            level = Some(renderer(&mut app).gpu_memory_in_use());
        }
        if frame % 50 == 0 {
            assert_no_validation_errors(&mut app);
        }
    }
    renderer(&mut app).finish();
    let end = renderer(&mut app).gpu_memory_in_use();
    assert_eq!(Some(end), level, "GPU memory in use returns to its level");
    assert_no_validation_errors(&mut app);
}

#[test]
fn deferred_decals_work_with_the_camera_inside_the_box_and_behind_occluders() {
    let (mut app, view) = decal_plane_app();
    let cyan = Vec3::new(0.0, 1.0, 1.0);
    // A box 10 m deep around the camera (at 4 m height): its front faces are behind the camera.
    let material =
        app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial { base_color: Some(cyan.extend(1.0)), ..Default::default() });
    let huge = Transform::from_xyz(-1.5, 0.0, 0.0)
        .with_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(2.0, 2.0, 10.0));
    app.world.spawn((Decal::new(material), huge));
    // A decal under an opaque slab: the slab hides it, so it must not show.
    let slab_mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(1.0, 0.1, 1.0), 1.0));
    let slab_material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.1, 0.1, 0.1, 1.0), 0.0, 0.5));
    app.world.spawn((MeshInstance { mesh: slab_mesh, material: slab_material }, Transform::from_xyz(1.5, 0.6, 0.0)));
    flat_decal(&mut app, Vec3::new(1.0, 0.0, 0.0), 1.0, Vec3::new(1.5, 0.0, 0.0), 0, 1.0);

    for method in [DecalMethod::RayQuery, DecalMethod::DeferredDecals] {
        let (albedo, _) = render_with(&mut app, PipelineKind::Deferred, method, DebugView::Albedo);
        assert_no_validation_errors(&mut app);
        let at = |p: Vec3| {
            let (px, py) = view.pixel_of(p);
            Vec3::from_slice(&albedo[(py * SIZE.0 + px) as usize][..3])
        };
        assert!(
            (at(Vec3::new(-1.5, 0.0, 0.0)) - cyan).abs().max_element() < 0.01,
            "{method:?}: camera inside the box: {}",
            at(Vec3::new(-1.5, 0.0, 0.0))
        );
        let slab_top = at(Vec3::new(1.5, 0.65, 0.0));
        assert!((slab_top - Vec3::splat(0.1)).abs().max_element() < 0.01, "{method:?}: the slab is not painted: {slab_top}");
    }
}

/// Where the compact-vertex references live, and whether this run rewrites them
/// (`UPDATE_REFERENCES=1`, only when a change is meant to alter the images).
fn reference_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("references").join(format!("{name}.png"))
}

/// Compact vertices (octahedral normals and tangents, 16-bit UVs: `render::layout::GpuVertex`)
/// draw as the 32-bit ones did, in every pipeline: a normal-mapped, textured floor and sphere
/// and the skinned, textured Fox, against references rendered by the 32-bit layout (commit
/// 203aa25, with `UPDATE_REFERENCES=1`). Stated errors on the displayed 8-bit image, every
/// channel: mean ≤ 0.1, 99th percentile ≤ 2, largest ≤ 8 (measured: means 0.007 to 0.017, 99th
/// percentiles 0 to 1, largest 2 to 3; the visibility buffer, which unpacks every attribute
/// per pixel, the most).
#[test]
fn compact_vertices_draw_as_32_bit_ones_did() {
    let size = (96u32, 64u32);
    let mut app = gpu_app(size.0, size.1, RenderSettings::default());
    let (stone, stone_normal) = sandbox::scene::textures::stone_tiles(64);
    let (brick, brick_normal) = sandbox::scene::textures::bricks(64);
    let textured = |app: &mut App, (albedo, normal): (Image, Image)| {
        let mut images = app.world.resource_mut::<Assets<Image>>();
        let (albedo, normal) = (images.add(albedo), images.add(normal));
        let material = Material { base_color_texture: Some(albedo), normal_texture: Some(normal), roughness: 0.5, ..Default::default() };
        app.world.resource_mut::<Assets<Material>>().add(material)
    };
    let (floor_material, sphere_material) = (textured(&mut app, (stone, stone_normal)), textured(&mut app, (brick, brick_normal)));
    let floor = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(6.0, 6.0, 4, 0.5));
    let sphere = app.world.resource_mut::<Assets<Mesh>>().add(shapes::uv_sphere(0.6, 24, 12));
    app.world.spawn((MeshInstance { mesh: floor, material: floor_material }, Transform::IDENTITY));
    app.world.spawn((MeshInstance { mesh: sphere, material: sphere_material }, Transform::from_xyz(-0.9, 0.6, 0.0)));
    let options = engine::gltf::LoadOptions { textures: engine::gltf::TextureImport::Rgba8, ..Default::default() };
    let fox = engine::gltf::load_with(&tests::shared_gltf_dir().join("Fox/Fox.glb"), &options).expect("the Fox loads");
    let fox = fox.spawn(&mut app.world);
    app.world.entity_mut(fox).insert(Transform::from_xyz(0.8, 0.0, 0.0).with_scale(Vec3::splat(0.02)));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.6, 3.2).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));
    app.world.spawn((
        // Hard shadows: the references hold no penumbra's dither.
        DirectionalLight { illuminance: 4.0, angular_diameter: 0.0, ..Default::default() },
        Transform::IDENTITY.looking_at(Vec3::new(0.4, -1.0, -0.5), Vec3::Y),
    ));
    let update = std::env::var_os("UPDATE_REFERENCES").is_some();
    for pipeline in PipelineKind::ALL {
        app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
        for _ in 0..3 {
            app.update();
        }
        assert_no_validation_errors(&mut app);
        let image = renderer(&mut app).read_display().expect("the display reads back");
        let path = reference_path(&format!("compact_vertices_{}", pipeline.name()));
        if update {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            image::save_buffer(&path, &image, size.0, size.1, image::ExtendedColorType::Rgba8).unwrap();
            continue;
        }
        let reference = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).into_rgba8().into_raw();
        let mut errors: Vec<u8> =
            image.iter().zip(&reference).enumerate().filter(|(i, _)| i % 4 != 3).map(|(_, (a, b))| a.abs_diff(*b)).collect();
        errors.sort_unstable();
        let mean = errors.iter().map(|&e| e as f32).sum::<f32>() / errors.len() as f32;
        let (p99, max) = (errors[errors.len() * 99 / 100], errors[errors.len() - 1]);
        eprintln!("{}: mean {mean:.3}, 99th percentile {p99}, max {max} (8-bit display values)", pipeline.name());
        assert!(mean <= 0.1 && p99 <= 2 && max <= 8, "{}: mean {mean}, 99th percentile {p99}, largest {max}", pipeline.name());
    }
}
