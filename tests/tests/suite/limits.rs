//! Limits and device failure: what happens when the scene tables are full (tested at reduced
//! limits, without a GPU) and when GPU memory runs out (tested with a small memory budget):
//! extra entities wait for room with one warning per kind; exhausted memory ends the app with an
//! error naming the frame, the operation and the allocation, and nothing panics.

use engine::app::AppExit;
use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{GpuRenderer, MirrorSlots, RenderMirror, RenderSettings, RenderStats, SceneLimits};
use render::RendererSettings;
use tests::{WarningLog, assert_no_validation_errors, ecs_app, gpu_app_with, renderer};

fn limit_warnings(log: &WarningLog) -> usize {
    log.warnings().iter().filter(|w| w.message.contains("limit of")).count()
}

#[test]
fn entities_past_a_table_limit_wait_for_room_with_one_warning_per_kind() {
    let mut app = ecs_app();
    let log = WarningLog::capture(&mut app);
    app.world.resource_mut::<RenderSettings>().limits = SceneLimits { instances: 3, lights: 2, decals: 4 };
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(1.0, 1.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::default());
    let decal_material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    let instances: Vec<Entity> =
        (0..5).map(|i| app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(i as f32, 0.0, 0.0))).id()).collect();
    let lights: Vec<Entity> =
        (0..4).map(|i| app.world.spawn((PointLight::default(), Transform::from_xyz(i as f32, 1.0, 0.0))).id()).collect();
    let decals: Vec<Entity> =
        (0..6).map(|i| app.world.spawn((Decal::new(decal_material), Transform::from_xyz(i as f32, 0.0, 0.0))).id()).collect();
    for _ in 0..3 {
        app.update();
    }
    let counts = |app: &App| {
        let m = &app.world.resource::<RenderMirror>().0;
        let over = app.world.resource::<RenderStats>().over_limit;
        ((m.instances.len(), m.lights.len(), m.decals.len()), (over.instances, over.lights, over.decals))
    };
    assert_eq!(counts(&app), ((3, 2, 4), (2, 2, 2)), "tables stop at their limits; the rest wait");
    assert_eq!(limit_warnings(&log), 3, "one warning per full table, not per entity or frame: {:?}", log.warnings());

    // Despawning makes room: waiting entities take it in the next frame.
    let slots = app.world.resource::<MirrorSlots>();
    let drawn_decal = *decals.iter().find(|&&e| slots.decal(e).is_some()).unwrap();
    let waiting_decals: Vec<Entity> = decals.iter().copied().filter(|&e| slots.decal(e).is_none()).collect();
    let drawn_light = *lights.iter().find(|&&e| slots.light(e).is_some()).unwrap();
    app.world.despawn(drawn_decal);
    app.world.despawn(drawn_light);
    app.update();
    assert_eq!(counts(&app), ((3, 2, 4), (2, 1, 1)));
    let slots = app.world.resource::<MirrorSlots>();
    assert_eq!(waiting_decals.iter().filter(|&&e| slots.decal(e).is_some()).count(), 1, "one waiting decal got the free slot");

    // Once everything fits, a later overflow warns again (once).
    for &e in instances.iter().take(2) {
        app.world.despawn(e);
    }
    app.update();
    assert_eq!(counts(&app).1.0, 0, "every instance fits");
    for i in 0..3 {
        app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(i as f32, 5.0, 0.0)));
    }
    app.update();
    app.update();
    assert_eq!(counts(&app).0.0, 3);
    assert_eq!(counts(&app).1.0, 3, "three fitted, three more arrived");
    assert_eq!(limit_warnings(&log), 4, "{:?}", log.warnings());
}

#[test]
fn running_out_of_gpu_memory_ends_the_app_with_an_error_naming_the_frame_and_allocation() {
    let size = (64, 48);
    // The memory a small scene needs, measured, then a budget with 2 MiB to spare.
    let spawn_scene = |app: &mut App| {
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
        let material = app.world.resource_mut::<Assets<Material>>().add(Material::default());
        app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 4.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z)));
    };
    let mut app = gpu_app_with(size.0, size.1, RenderSettings::default(), &RendererSettings::default());
    spawn_scene(&mut app);
    for _ in 0..3 {
        app.update();
    }
    renderer(&mut app).finish();
    let needed = renderer(&mut app).gpu_memory_in_use();
    drop(app);

    let mut settings = RendererSettings::default();
    settings.device.memory_budget = Some(needed + (2 << 20));
    let mut app = gpu_app_with(size.0, size.1, RenderSettings::default(), &settings);
    spawn_scene(&mut app);
    for _ in 0..3 {
        app.update();
    }
    assert!(!app.exit_requested(), "the scene fits its budget");
    // 40,000 decals need about 5 MiB of records alone: past the budget.
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    app.world.spawn_batch(
        (0..40_000).map(move |i| (Decal::new(material), Transform::from_xyz((i % 200) as f32 * 0.01, 0.0, (i / 200) as f32 * 0.01))),
    );
    app.update();
    let Some(AppExit::Error(message)) = app.world.get_resource::<AppExit>().cloned() else {
        panic!("running out of memory ends the app with an error");
    };
    assert!(message.contains("frame 3:"), "names the frame: {message}");
    assert!(message.contains("uploading the scene"), "names the operation: {message}");
    assert!(message.contains("out of GPU memory allocating") && message.contains("budget"), "names the allocation: {message}");
    assert!(app.exit_result().is_err());
    println!("{message}");
    // Later frames render nothing and do not fail again; nothing panics on the way out.
    let error = app.world.resource::<RenderStats>().last_error.clone();
    app.update();
    assert_eq!(app.world.resource::<RenderStats>().last_error, error);
    assert!(renderer(&mut app).gpu_memory_in_use() <= needed + (2 << 20), "the budget held");
    assert_no_validation_errors(&mut app);
    drop(app.world.remove_resource::<GpuRenderer>());
}
