//! Any glTF or GLB file, framed by its bounds at any scale (the camera's near plane follows the
//! model's size), with orbit controls: drag with the left button to turn around it, W/S to move
//! closer or away, 1–4 for the forward, Forward+, deferred and visibility-buffer pipelines, and
//! the overlay (F1) for the rest.
//!
//! `cargo run --example gltf_viewer -- path/to/model.glb` (`--headless` renders offscreen).

use engine::app::BoxError;
use engine::prelude::*;
use plugins::overlay::OverlayPlugin;
use plugins::run::RunPlugin;
use plugins::{GpuPlugin, RenderPlugin, RenderSettings};
use render::PipelineKind;

/// The orbit: what it turns around, how far, its angles, and where the cursor last was.
#[derive(Resource)]
struct Orbit {
    centre: Vec3,
    distance: f32,
    yaw: f32,
    pitch: f32,
    cursor: Option<Vec2>,
}

fn main() -> Result<(), BoxError> {
    // The one argument that is neither a flag nor a flag's value.
    let (mut args, mut path) = (std::env::args().skip(1), None);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--frames" | "--size" | "--screenshot" => drop(args.next()),
            flag if flag.starts_with("--") => {}
            _ => path = Some(arg),
        }
    }
    let path = path.ok_or("usage: gltf_viewer MODEL.gltf|MODEL.glb [--headless]")?;
    let mut app = App::new();
    app.add_plugins(RenderPlugin::new(RenderSettings { ambient: Vec3::splat(0.2), ..Default::default() }));
    app.add_plugins(GpuPlugin::default());
    app.add_plugins(engine::input::InputPlugin);
    app.add_plugins(OverlayPlugin::default());
    app.add_plugins(RunPlugin::from_args("gltf viewer"));

    // A bad file is an error naming the file, not a panic.
    engine::gltf::load(path.as_ref()).map_err(|e| format!("{path}: {e}"))?.spawn(&mut app.world);
    // Drop the file's own cameras: the viewer orbits its own.
    let cameras: Vec<Entity> = app.world.query_filtered::<Entity, With<Camera>>().iter(&app.world).collect();
    for camera in cameras {
        app.world.entity_mut(camera).remove::<Camera>();
    }
    // The orbit starts where frame_scene put the camera.
    let framed = engine::scene::frame_scene(&mut app.world);
    let eye = app.world.query_filtered::<&Transform, With<Camera>>().iter(&app.world).next().map_or(Vec3::Z, |t| t.translation);
    let offset = eye - framed.centre;
    let (distance, yaw, pitch) = (offset.length(), offset.x.atan2(offset.z), (offset.y / offset.length()).asin());
    app.world.insert_resource(Orbit { centre: framed.centre, distance, yaw, pitch, cursor: None });

    app.add_systems(Update, (orbit, switch_pipeline));
    app.run()
}

/// Turns the camera around the model while the left button is held; W/S change the distance.
fn orbit(mut state: ResMut<Orbit>, input: Res<Input>, time: Res<Time>, mut cameras: Query<&mut Transform, With<Camera>>) {
    if let (true, Some(now), Some(before)) = (input.button_pressed(MouseButton::Left), input.cursor, state.cursor) {
        let drag = now - before;
        state.yaw -= drag.x * 0.005;
        state.pitch = (state.pitch + drag.y * 0.005).clamp(-1.5, 1.5);
    }
    state.cursor = input.cursor;
    let zoom = if input.pressed(Key::W) {
        -1.0
    } else if input.pressed(Key::S) {
        1.0
    } else {
        0.0
    };
    state.distance *= 1.0 + zoom * time.delta_secs();
    let offset = Vec3::new(state.yaw.sin() * state.pitch.cos(), state.pitch.sin(), state.yaw.cos() * state.pitch.cos());
    for mut transform in &mut cameras {
        *transform = Transform::from_translation(state.centre + offset * state.distance).looking_at(state.centre, Vec3::Y);
    }
}

/// Keys 1–4 choose the pipeline.
fn switch_pipeline(input: Res<Input>, mut settings: ResMut<RenderSettings>) {
    let pipelines = [PipelineKind::Forward, PipelineKind::ForwardPlus, PipelineKind::Deferred, PipelineKind::VisBuffer];
    for (i, pipeline) in pipelines.into_iter().enumerate() {
        if Key::digit(i as u32 + 1).is_some_and(|k| input.just_pressed(k)) {
            settings.pipeline = pipeline;
        }
    }
}
