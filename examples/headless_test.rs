//! The pattern for testing your own systems: build the app without a window, step frames, and
//! assert on the ECS state, the renderer's counters and a read-back image. Copy it into your
//! crate's `tests/` as a `#[test]`; here it runs as a program (`cargo run --example
//! headless_test`) and fails with a message when an assertion does.

use engine::app::BoxError;
use engine::prelude::*;
use plugins::decal::{Decal, DecalLifetime, DecalMaterial};
use plugins::{GpuPlugin, GpuRenderer, RenderPlugin, RenderSettings, RenderStats};

fn main() -> Result<(), BoxError> {
    // No window: the renderer draws offscreen at this size. A fixed time step makes the run
    // the same on every machine.
    let mut app = App::new();
    app.add_plugins(RenderPlugin::new(RenderSettings { size: (160, 120), ..Default::default() }));
    app.add_plugins(GpuPlugin::default());
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_secs_f64(1.0 / 60.0)));

    let floor = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(4.0, 4.0, 1, 1.0));
    let white = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::ONE, 0.0, 0.8));
    app.world.spawn((MeshInstance { mesh: floor, material: white }, Transform::default()));
    app.world.spawn((DirectionalLight { illuminance: 2.0, ..Default::default() }, Transform::default().looking_at(Vec3::NEG_Y, Vec3::Z)));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 3.0, 0.01).looking_at(Vec3::ZERO, Vec3::Y)));
    // A black decal in the middle of the floor that lives half a second.
    let black = app
        .world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(Vec4::new(0.0, 0.0, 0.0, 1.0)), ..Default::default() });
    let decal = Transform::from_xyz(0.0, 0.0, 0.0).looking_at(Vec3::NEG_Y, Vec3::Z).with_scale(Vec3::new(1.0, 1.0, 0.5));
    app.world.spawn((Decal::new(black), decal, DecalLifetime::new(0.5, 0.0)));

    // Frame 1 uploads everything; frame 2 changes nothing, so it uploads nothing.
    app.update();
    check(app.world.resource::<RenderStats>().last.decals == 1, "one live decal after the first frame")?;
    app.update();
    check(app.world.resource::<RenderStats>().last.bytes_uploaded == 0, "a still frame uploads nothing")?;

    // The read-back image: the centre is dark under the decal, the corners lit.
    let renderer = &mut app.world.resource_mut::<GpuRenderer>().0;
    let pixels = renderer.read_display()?;
    let luma = |x: usize, y: usize| pixels[(y * 160 + x) * 4] as u32 + pixels[(y * 160 + x) * 4 + 1] as u32;
    check(luma(80, 60) + 60 < luma(10, 10), "the decal darkens the middle of the floor")?;

    // Half a second later the lifetime system has despawned it, and the ECS agrees.
    for _ in 0..40 {
        app.update();
    }
    let decals = app.world.query::<&Decal>().iter(&app.world).count();
    check(decals == 0 && app.world.resource::<RenderStats>().last.decals == 0, "the decal expired")?;
    let errors = app.world.resource::<GpuRenderer>().0.take_validation_errors();
    check(errors.is_empty(), "no Vulkan validation errors")?;
    println!("headless_test: all checks passed");
    Ok(())
}

/// Fails the run with `what` when `ok` is false (in a `#[test]`, use `assert!`).
fn check(ok: bool, what: &str) -> Result<(), BoxError> {
    if ok { Ok(()) } else { Err(format!("check failed: {what}").into()) }
}
