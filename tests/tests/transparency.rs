//! Blended transparency (`AlphaMode::Blend`, `render::transparency`) in every pipeline, on
//! lavapipe, against the analytic "over" blend of images rendered without transparency.
//!
//! The scene, seen from above: a grey floor, a directional light, and a point light just above
//! a 40 %-opaque red pane whose range reaches the pane but not the floor (so only tile lists
//! that hold the glass's depth light the pane with it). References: the floor alone (`B`, in
//! the pipeline under test) and the pane made opaque (`P`, in the forward pipeline, whose shader
//! the transparency pass shares). Where the pane covers the floor the image must be
//! `0.4·P + 0.6·B`, and elsewhere `B`. A second, 50 %-opaque blue pane below the red one,
//! in the slot after it, checks the back-to-front order: where both cover the floor the image must be
//! `0.4·P_red + 0.6·(0.5·P_blue + 0.5·B)`.
//!
//! Tolerance: |image − expected| ≤ 0.002 + 0.002·expected per channel, on linear radiance read
//! back from the fp16 HDR target (the blend runs on fp16 values; one fp16 step is 0.1 %).
//! Measured: worst 0.00076 over the 4 pipelines. Drawing the panes front to back fails it (0.51
//! against 0.83 where they overlap), and so does culling lights without the glass's depth (the
//! point light goes missing from the red pane).

#![forbid(unsafe_code)]

use engine::prelude::*;
use plugins::RenderSettings;
use render::{DecalMethod, PipelineKind};
use tests::{TopDownView, assert_no_validation_errors, gpu_app, renderer};

const SIZE: (u32, u32) = (128, 96);
const RED_ALPHA: f32 = 0.4;
const BLUE_ALPHA: f32 = 0.5;

struct Scene {
    app: App,
    red: Entity,
    blue: Entity,
    red_material: Handle<Material>,
    blue_material: Handle<Material>,
}

fn scene() -> Scene {
    let mut app = gpu_app(SIZE.0, SIZE.1, RenderSettings { decal_method: DecalMethod::Off, ..Default::default() });
    TopDownView::new(10.0, SIZE).spawn(&mut app.world);
    let (floor, pane, small) = {
        let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(shapes::plane(20.0, 20.0, 1, 1.0)),
            meshes.add(shapes::plane(3.0, 3.0, 1, 1.0)),
            meshes.add(shapes::plane(2.0, 2.0, 1, 1.0)),
        )
    };
    let (grey, red_material, blue_material) = {
        let mut materials = app.world.resource_mut::<Assets<Material>>();
        let glass = |rgb: Vec3, alpha: f32| Material { alpha_mode: AlphaMode::Blend, ..Material::from_color(rgb.extend(alpha), 0.0, 0.3) };
        (
            materials.add(Material::from_color(Vec4::new(0.7, 0.7, 0.7, 1.0), 0.0, 0.8)),
            materials.add(glass(Vec3::new(0.9, 0.1, 0.1), RED_ALPHA)),
            materials.add(glass(Vec3::new(0.1, 0.2, 0.9), BLUE_ALPHA)),
        )
    };
    app.world.spawn((MeshInstance { mesh: floor, material: grey }, Transform::default()));
    app.world.spawn((
        DirectionalLight { illuminance: 2.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.2, -1.0, 0.1), Vec3::Z),
    ));
    // Reaches the red pane (0.6 m below) and not the floor (2.1 m below).
    app.world.spawn((PointLight { intensity: 3.0, range: Some(1.2), ..Default::default() }, Transform::from_xyz(0.3, 2.1, 0.2)));
    // The nearer pane takes the lower slot: drawn in slot order, the blend would come out wrong.
    let red = app.world.spawn((MeshInstance { mesh: pane, material: red_material }, Transform::from_xyz(0.0, 1.5, 0.0))).id();
    let blue = app.world.spawn((MeshInstance { mesh: small, material: blue_material }, Transform::from_xyz(1.2, 0.5, 0.8))).id();
    Scene { app, red, blue, red_material, blue_material }
}

fn render(app: &mut App, pipeline: PipelineKind) -> (Vec<[f32; 4]>, Vec<f32>) {
    app.world.resource_mut::<RenderSettings>().pipeline = pipeline;
    app.update();
    assert_no_validation_errors(app);
    let r = renderer(app);
    (r.read_hdr().unwrap(), r.read_depth().unwrap())
}

fn set_alpha_mode(app: &mut App, material: Handle<Material>, mode: AlphaMode) {
    app.world.resource_mut::<Assets<Material>>().get_mut(material).unwrap().alpha_mode = mode;
}

fn set_visible(app: &mut App, entity: Entity, visible: bool, mesh: &mut Option<MeshInstance>) {
    if visible {
        if let Some(m) = mesh.take() {
            app.world.entity_mut(entity).insert(m);
        }
    } else if mesh.is_none() {
        *mesh = app.world.entity_mut(entity).take::<MeshInstance>();
    }
}

#[test]
fn blended_panes_equal_the_analytic_over_blend_in_every_pipeline() {
    let Scene { mut app, red, blue, red_material, blue_material } = scene();
    let (mut red_mesh, mut blue_mesh) = (None, None);

    // References in the forward pipeline: each pane alone and opaque (its lit colour).
    set_alpha_mode(&mut app, red_material, AlphaMode::Opaque);
    set_alpha_mode(&mut app, blue_material, AlphaMode::Opaque);
    set_visible(&mut app, blue, false, &mut blue_mesh);
    let (red_lit, red_depth) = render(&mut app, PipelineKind::Forward);
    set_visible(&mut app, blue, true, &mut blue_mesh);
    set_visible(&mut app, red, false, &mut red_mesh);
    let (blue_lit, blue_depth) = render(&mut app, PipelineKind::Forward);
    set_visible(&mut app, red, true, &mut red_mesh);
    set_alpha_mode(&mut app, red_material, AlphaMode::Blend);
    set_alpha_mode(&mut app, blue_material, AlphaMode::Blend);

    let mut worst = 0.0f32;
    for pipeline in [PipelineKind::Forward, PipelineKind::ForwardPlus, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        // The floor alone, in this pipeline.
        set_visible(&mut app, red, false, &mut red_mesh);
        set_visible(&mut app, blue, false, &mut blue_mesh);
        let (floor, floor_depth) = render(&mut app, pipeline);
        set_visible(&mut app, red, true, &mut red_mesh);
        set_visible(&mut app, blue, true, &mut blue_mesh);
        let (image, depth) = render(&mut app, pipeline);
        assert!(depth == floor_depth, "{pipeline:?}: blended panes write no depth");

        let (mut red_pixels, mut both_pixels) = (0, 0);
        for i in 0..image.len() {
            let over_red = red_depth[i] > floor_depth[i];
            let over_blue = blue_depth[i] > floor_depth[i];
            red_pixels += usize::from(over_red);
            both_pixels += usize::from(over_red && over_blue);
            for c in 0..3 {
                let behind_red = if over_blue { BLUE_ALPHA * blue_lit[i][c] + (1.0 - BLUE_ALPHA) * floor[i][c] } else { floor[i][c] };
                let expected = if over_red { RED_ALPHA * red_lit[i][c] + (1.0 - RED_ALPHA) * behind_red } else { behind_red };
                let error = (image[i][c] - expected).abs();
                worst = worst.max(error);
                assert!(
                    error <= 0.002 + 0.002 * expected.abs(),
                    "{pipeline:?}: pixel ({}, {}) channel {c}: {} against the blend {expected} (red pane {over_red}, blue {over_blue})",
                    i % SIZE.0 as usize,
                    i / SIZE.0 as usize,
                    image[i][c]
                );
            }
        }
        assert!(red_pixels > 500 && both_pixels > 100, "{pipeline:?}: the panes cover the view ({red_pixels}, {both_pixels} pixels)");
    }
    eprintln!("worst error against the analytic blend: {worst:.5}");
}
