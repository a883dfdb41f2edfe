//! Headless ECS tests: no GPU. Extraction must mirror spawns, changes and despawns into stable
//! slots, and a frame in which nothing changed must write nothing.

#![forbid(unsafe_code)]

use engine::prelude::*;
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
    let light = app.world.spawn((PointLight { color: Vec3::ONE, intensity: 8.0, range: None }, Transform::from_xyz(0.0, 4.0, 0.0))).id();
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
    app.world.spawn((DirectionalLight { color: Vec3::ONE, illuminance: 2.0 }, Transform::default()));
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
