//! Headless ECS tests: no GPU. Extraction must mirror spawns, changes and despawns into stable
//! slots, and a frame in which nothing changed must write nothing.

use engine::prelude::*;
use plugins::decal::{Decal, DecalLifetime, DecalMaterial};
use plugins::{MirrorSlots, RenderMirror, RenderStats};
use render::scene::LightKind;
use tests::ecs_app;

fn quad_assets(app: &mut App) -> (Handle<Mesh>, Handle<Material>) {
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(1.0, 1.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(1.0, 0.0, 0.0, 1.0), 0.0, 0.5));
    (mesh, material)
}

fn model_of(app: &App, entity: Entity) -> Option<Mat4> {
    let slot = app.world.resource::<MirrorSlots>().instance(entity)?;
    app.world.resource::<RenderMirror>().0.instances.get(slot).map(|r| r.model)
}

#[test]
fn parent_motion_propagates_to_the_mirrored_child() {
    let mut app = ecs_app();
    let (mesh, material) = quad_assets(&mut app);
    let parent = app.world.spawn(Transform::from_xyz(1.0, 0.0, 0.0)).id();
    let child = app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(0.0, 2.0, 0.0), ChildOf(parent))).id();
    app.update();
    let m = model_of(&app, child).expect("child mirrored");
    assert_eq!(m.w_axis.truncate(), Vec3::new(1.0, 2.0, 0.0));

    app.world.get_mut::<Transform>(parent).unwrap().translation = Vec3::new(5.0, 0.0, 0.0);
    app.update();
    assert_eq!(model_of(&app, child).unwrap().w_axis.truncate(), Vec3::new(5.0, 2.0, 0.0));
    assert_eq!(app.world.resource::<RenderStats>().last.records_written, 1, "only the child's record was rewritten");
}

#[test]
fn spawn_change_despawn_and_respawn_reach_the_mirror() {
    let mut app = ecs_app();
    let (mesh, material) = quad_assets(&mut app);
    let a = app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(0.0, 0.0, 0.0))).id();
    let b = app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(3.0, 0.0, 0.0))).id();
    let light = app
        .world
        .spawn((PointLight { color: Vec3::ONE, intensity: 8.0, range: None, radius: 0.0 }, Transform::from_xyz(0.0, 4.0, 0.0)))
        .id();
    app.update();

    let slots = app.world.resource::<MirrorSlots>();
    let (slot_a, slot_b) = (slots.instance(a).unwrap(), slots.instance(b).unwrap());
    let light_slot = slots.light(light).unwrap();
    let mirror = &app.world.resource::<RenderMirror>().0;
    assert_eq!(mirror.instances.len(), 2);
    assert!(mirror.draws[slot_a as usize].is_some());
    let l = mirror.lights.get(light_slot).unwrap();
    assert_eq!(l.kind, LightKind::Point as u32);
    assert_eq!(l.position, Vec3::new(0.0, 4.0, 0.0));
    assert!((l.range - engine::light::range_from_intensity(8.0)).abs() < 1e-4, "range from eq. 4.1");
    let mat_slot = app.world.resource::<MirrorSlots>().material(material).unwrap();
    assert_eq!(mirror.instances.get(slot_a).unwrap().material, mat_slot);
    assert_eq!(mirror.materials.get(mat_slot).unwrap().base_color, [1.0, 0.0, 0.0, 1.0]);

    // Move b: same slot, new matrix, one record.
    app.world.get_mut::<Transform>(b).unwrap().translation.x = 7.0;
    app.update();
    assert_eq!(app.world.resource::<MirrorSlots>().instance(b), Some(slot_b));
    assert_eq!(model_of(&app, b).unwrap().w_axis.x, 7.0);
    assert_eq!(app.world.resource::<RenderStats>().last.records_written, 1);

    // Despawn a and the light: slots freed, records zeroed.
    app.world.despawn(a);
    app.world.despawn(light);
    app.update();
    let mirror = &app.world.resource::<RenderMirror>().0;
    assert_eq!(mirror.instances.len(), 1);
    assert!(mirror.instances.get(slot_a).is_none());
    assert!(mirror.draws[slot_a as usize].is_none());
    assert_eq!(mirror.lights.records()[light_slot as usize].kind, LightKind::None as u32, "a freed light slot is empty");
    assert_eq!(app.world.resource::<MirrorSlots>().instance(a), None);

    // Respawn: the freed slot is reused.
    let c = app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(1.0, 1.0, 1.0))).id();
    app.update();
    assert_eq!(app.world.resource::<MirrorSlots>().instance(c), Some(slot_a));
    assert_eq!(app.world.resource::<RenderMirror>().0.instances.len(), 2);
}

#[test]
fn a_frame_without_changes_writes_nothing() {
    let mut app = ecs_app();
    let (mesh, material) = quad_assets(&mut app);
    for i in 0..10 {
        app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(i as f32, 0.0, 0.0)));
    }
    app.world.spawn((DirectionalLight { color: Vec3::ONE, illuminance: 2.0, angular_diameter: 0.0 }, Transform::default()));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 5.0)));
    app.update();
    let first = app.world.resource::<RenderStats>().last;
    assert_eq!(first.records_written, 10 + 1 + 1 + 1, "10 instances, 1 light, 1 material and the camera");
    // Stand in for the GPU uploader, which would drain the mirror here.
    app.world.resource_mut::<RenderMirror>().0.clear_dirty();
    for _ in 0..3 {
        app.update();
        let stats = app.world.resource::<RenderStats>().last;
        assert_eq!(stats.records_written, 0);
        let mirror = &app.world.resource::<RenderMirror>().0;
        assert!(mirror.is_clean(), "nothing queued for upload");
    }
}

#[test]
fn decal_receiver_layers_reach_the_instance_record() {
    use plugins::decal::{DEFAULT_RECEIVER_LAYERS, DecalReceiver};
    let mut app = ecs_app();
    let (mesh, material) = quad_assets(&mut app);
    let e = app.world.spawn((MeshInstance { mesh, material }, Transform::default())).id();
    app.update();
    let layers = |app: &App| {
        let slot = app.world.resource::<MirrorSlots>().instance(e).unwrap();
        app.world.resource::<RenderMirror>().0.instances.get(slot).unwrap().decal_layers
    };
    assert_eq!(layers(&app), DEFAULT_RECEIVER_LAYERS);
    app.world.entity_mut(e).insert(DecalReceiver(0b100));
    app.update();
    assert_eq!(layers(&app), 0b100);
    app.world.entity_mut(e).remove::<DecalReceiver>();
    app.update();
    assert_eq!(layers(&app), DEFAULT_RECEIVER_LAYERS, "removing the component restores the default");
}

/// Every live decal's record and box in the mirror, by entity (the box's slot left out: slots
/// may differ between two extractions, their contents may not).
fn decal_records(app: &mut App) -> std::collections::HashMap<Entity, (render::scene::GpuDecal, [f32; 6])> {
    let entities: Vec<Entity> = app.world.query_filtered::<Entity, With<Decal>>().iter(&app.world).collect();
    let slots = app.world.resource::<MirrorSlots>();
    let table = &app.world.resource::<RenderMirror>().0.decals;
    let boxes: std::collections::HashMap<u32, [f32; 6]> = (0..table.len() as u32)
        .filter_map(|i| table.aabbs.get(i))
        .map(|b| (b.slot, [b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2]]))
        .collect();
    entities
        .into_iter()
        .map(|e| {
            let slot = slots.decal(e).expect("every decal has a slot");
            (e, (*table.records.get(slot).expect("a record"), boxes[&slot]))
        })
        .collect()
}

#[test]
fn decal_extraction_visits_only_what_changed_and_equals_a_full_re_extraction() {
    let mut app = ecs_app();
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    let n = 100_000;
    let fixed: Vec<Entity> = app
        .world
        .spawn_batch((0..n).map(|i| (Decal::new(material), Transform::from_xyz((i % 300) as f32, 0.0, (i / 300) as f32), Static)))
        .collect();
    let free: Vec<Entity> = (0..4).map(|i| app.world.spawn((Decal::new(material), Transform::from_xyz(i as f32, 1.0, 0.0))).id()).collect();
    let mover = app.world.spawn(Transform::from_xyz(0.0, 5.0, 0.0)).id();
    let riding: Vec<Entity> = (0..3)
        .map(|i| app.world.spawn((Decal::new(material), Transform::from_xyz(i as f32, 0.0, 0.0), Static, ChildOf(mover))).id())
        .collect();
    app.update();
    let visited = |app: &App| app.world.resource::<RenderStats>().visited.decals;
    assert_eq!(visited(&app), n as u64 + 7, "the first frame visits every decal");
    app.update();
    assert_eq!((visited(&app), app.world.resource::<RenderStats>().last.records_written), (0, 0), "a still frame visits none");

    // Among the 100,000 untouched: spawn 10, edit 5, move 3 static ones (re-inserted transforms)
    // and 2 free ones (in place), re-parent 2 onto the mover, move the mover (carrying its 3
    // riders and the 2 re-parented), give 1 a lifetime, despawn 7.
    for i in 0..10 {
        app.world.spawn((Decal::new(material), Transform::from_xyz(i as f32, 2.0, 0.0), Static));
    }
    for &e in &fixed[0..5] {
        let edited = Decal { opacity: 0.5, weight: 2.0, ..app.world.get::<Decal>(e).unwrap().clone() };
        app.world.entity_mut(e).insert(edited);
    }
    for &e in &fixed[5..8] {
        app.world.entity_mut(e).insert(Transform::from_xyz(-1.0, 0.0, -1.0).with_scale(Vec3::splat(0.5)));
    }
    for &e in &free[0..2] {
        app.world.get_mut::<Transform>(e).unwrap().translation.y = 3.0;
    }
    for &e in &fixed[8..10] {
        app.world.entity_mut(e).insert(ChildOf(mover));
    }
    app.world.get_mut::<Transform>(mover).unwrap().translation.x = 7.0;
    app.world.entity_mut(fixed[10]).insert(DecalLifetime::new(60.0, 1.0));
    for &e in &fixed[11..18] {
        app.world.despawn(e);
    }
    app.update();
    assert_eq!(visited(&app), 10 + 5 + 3 + 2 + 2 + 3 + 1, "only the changed decals are visited");
    assert_eq!(app.world.resource::<RenderMirror>().0.decals.len(), n + 7 + 10 - 7);

    // The incremental mirror equals one extracted from scratch.
    let incremental = decal_records(&mut app);
    for (i, e) in riding.iter().enumerate() {
        let b = incremental[e].1;
        assert!(((b[0] + b[3]) * 0.5 - (7.0 + i as f32)).abs() < 1e-4, "rider {i} follows the mover: {b:?}");
    }
    plugins::reset_mirror(&mut app.world);
    app.update();
    assert_eq!(visited(&app), (n + 7 + 10 - 7) as u64);
    let full = decal_records(&mut app);
    assert_eq!(incremental.len(), full.len());
    for (e, record) in &incremental {
        assert_eq!(Some(record), full.get(e), "decal {e:?}");
    }
    let lifetime = incremental[&fixed[10]].0;
    assert!(lifetime.life_scale < 0.0, "the lifetime fade reached the record");
}

/// Enough decals in a frame for extraction to read them on several tasks
/// (`plugins::extract::extract_decals`' first half): slots are still given out in the visits'
/// (the entities') order, a bad decal among them still lands nowhere, and moving them all (each
/// with a slot already) writes each in its own slot.
#[test]
fn a_large_batch_of_decals_is_extracted_in_order_with_its_bad_ones_inert() {
    let mut app = ecs_app();
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    let n = 3_000;
    let decals: Vec<Entity> =
        app.world.spawn_batch((0..n).map(|i| (Decal::new(material), Transform::from_xyz(i as f32, 0.0, 0.0)))).collect();
    let (singular, not_finite) = (decals[100], decals[2_000]);
    app.world.get_mut::<Transform>(singular).unwrap().scale = Vec3::ZERO;
    app.world.get_mut::<Transform>(not_finite).unwrap().translation.y = f32::NAN;
    app.update();
    let mut sorted = decals.clone();
    sorted.sort_unstable();
    // Where a decal's record takes the point it was placed at (its box's centre: the origin).
    let check = |app: &App, offset: f32, bad: &[Entity]| {
        let slots = app.world.resource::<MirrorSlots>();
        let records = &app.world.resource::<RenderMirror>().0.decals.records;
        for (i, &e) in decals.iter().enumerate() {
            let slot = slots.decal(e).expect("every decal has a slot");
            assert_eq!(sorted.get(slot as usize), Some(&e), "slots follow the entities' order");
            let record = records.get(slot).unwrap();
            if bad.contains(&e) {
                assert_eq!(record.receivers, 0, "decal {i} is invalid: it lands nowhere");
            } else {
                let at = record.world_to_decal.transform_point3(Vec3::new(i as f32 + offset, 0.0, 0.0));
                assert!(record.receivers != 0 && at.length() < 1e-3, "decal {i}'s record places it at {at}");
            }
        }
    };
    check(&app, 0.0, &[singular, not_finite]);
    assert_eq!(app.world.resource::<RenderStats>().visited.decals, n as u64);

    // All of them moved; the singular one mended.
    for &e in &decals {
        app.world.get_mut::<Transform>(e).unwrap().translation.x += 0.5;
    }
    app.world.get_mut::<Transform>(singular).unwrap().scale = Vec3::ONE;
    app.update();
    assert_eq!(app.world.resource::<RenderStats>().visited.decals, n as u64);
    assert_eq!(app.world.resource::<RenderMirror>().0.decals.len(), n);
    check(&app, 0.5, &[not_finite]);
}

#[test]
fn instance_and_light_extraction_visits_only_what_changed_and_equals_a_full_re_extraction() {
    use plugins::decal::DecalReceiver;
    let mut app = ecs_app();
    let (mesh, material) = quad_assets(&mut app);
    let blue = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.0, 0.0, 1.0, 1.0), 0.0, 0.5));
    let n = 10_000;
    let walls: Vec<Entity> =
        app.world.spawn_batch((0..n).map(|i| (MeshInstance { mesh, material }, Transform::from_xyz(i as f32, 0.0, 0.0), Static))).collect();
    let props: Vec<Entity> =
        (0..4).map(|i| app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(i as f32, 1.0, 0.0))).id()).collect();
    let lights: Vec<Entity> = (0..4)
        .map(|i| {
            app.world
                .spawn((PointLight { color: Vec3::ONE, intensity: 1.0, range: None, radius: 0.0 }, Transform::from_xyz(i as f32, 3.0, 0.0)))
                .id()
        })
        .collect();
    app.update();
    let visited = |app: &App| {
        let v = app.world.resource::<RenderStats>().visited;
        (v.instances, v.lights)
    };
    assert_eq!(visited(&app), (n as u64 + 4, 4), "the first frame visits everything");
    app.update();
    assert_eq!(visited(&app), (0, 0), "a still frame visits nothing");

    // Re-material 2 walls, give 1 a receiver layer, move 2 props, despawn 3 walls, spawn 2
    // instances; change 1 light, move another.
    for &e in &walls[0..2] {
        app.world.entity_mut(e).insert(MeshInstance { mesh, material: blue });
    }
    app.world.entity_mut(walls[2]).insert(DecalReceiver(0b10));
    for &e in &props[0..2] {
        app.world.get_mut::<Transform>(e).unwrap().translation.y = 2.0;
    }
    for &e in &walls[3..6] {
        app.world.despawn(e);
    }
    for i in 0..2 {
        app.world.spawn((MeshInstance { mesh, material: blue }, Transform::from_xyz(i as f32, 5.0, 0.0), Static));
    }
    app.world.entity_mut(lights[0]).insert(PointLight { color: Vec3::X, intensity: 4.0, range: Some(2.0), radius: 0.0 });
    app.world.get_mut::<Transform>(lights[1]).unwrap().translation.z = 1.0;
    app.update();
    assert_eq!(visited(&app), (2 + 1 + 2 + 2, 2), "only the changed instances and lights are visited");

    // The incremental mirror equals one extracted from scratch.
    let snapshot = |app: &mut App| {
        let instances: Vec<Entity> = app.world.query_filtered::<Entity, With<MeshInstance>>().iter(&app.world).collect();
        let slots = app.world.resource::<MirrorSlots>();
        let mirror = &app.world.resource::<RenderMirror>().0;
        let by_instance: std::collections::HashMap<Entity, render::scene::GpuInstance> =
            instances.iter().map(|&e| (e, *mirror.instances.get(slots.instance(e).expect("mirrored")).unwrap())).collect();
        let by_light: Vec<render::scene::GpuLight> = lights.iter().map(|&e| *mirror.lights.get(slots.light(e).unwrap()).unwrap()).collect();
        (by_instance, by_light)
    };
    let incremental = snapshot(&mut app);
    plugins::reset_mirror(&mut app.world);
    app.update();
    assert_eq!(visited(&app), ((n - 3 + 4 + 2) as u64, 4));
    let full = snapshot(&mut app);
    assert_eq!(incremental.1, full.1, "lights");
    assert_eq!(incremental.0.len(), full.0.len());
    for (e, record) in &incremental.0 {
        // Material slots are assigned in the same order by both extractions.
        assert_eq!(Some(record), full.0.get(e), "instance {e:?}");
    }
}
