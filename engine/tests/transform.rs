//! Headless tests of transform propagation through the app's `PostUpdate`.

#![forbid(unsafe_code)]

use std::time::Duration;

use engine::prelude::*;

/// Counts entities whose `GlobalTransform` changed since the counting system last ran.
#[derive(Resource, Default)]
struct ChangedGlobals(usize);

fn count_changed(query: Query<(), Changed<GlobalTransform>>, mut count: ResMut<ChangedGlobals>) {
    count.0 = query.iter().count();
}

fn app() -> App {
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_millis(16)));
    app.insert_resource(ChangedGlobals::default());
    app.add_systems(Render, count_changed);
    app
}

fn global(app: &App, entity: Entity) -> Vec3 {
    app.world.get::<GlobalTransform>(entity).unwrap().translation()
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn hierarchy_propagates_and_idles_without_changes() {
    let mut app = app();
    let parent = app.world.spawn(Transform::from_xyz(1.0, 0.0, 0.0).with_scale(Vec3::splat(2.0))).id();
    let child = app.world.spawn((Transform::from_xyz(0.0, 1.0, 0.0), ChildOf(parent))).id();
    let grandchild = app.world.spawn((Transform::from_xyz(0.0, 0.0, 1.0), ChildOf(child))).id();
    app.update();
    assert!(close(global(&app, parent), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(global(&app, child), Vec3::new(1.0, 2.0, 0.0)));
    assert!(close(global(&app, grandchild), Vec3::new(1.0, 2.0, 2.0)));
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 3);

    // Nothing moved: no GlobalTransform may be flagged changed.
    app.update();
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 0);
    app.update();
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 0);

    // Moving the parent moves every descendant.
    app.world.get_mut::<Transform>(parent).unwrap().translation = Vec3::new(0.0, 0.0, -5.0);
    app.update();
    assert!(close(global(&app, child), Vec3::new(0.0, 2.0, -5.0)));
    assert!(close(global(&app, grandchild), Vec3::new(0.0, 2.0, -3.0)));
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 3);

    // Writing an equal value flags Transform changed but GlobalTransform stays unflagged.
    app.world.get_mut::<Transform>(child).unwrap().translation = Vec3::new(0.0, 1.0, 0.0);
    app.update();
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 0);

    // Moving a leaf touches only the leaf.
    app.world.get_mut::<Transform>(grandchild).unwrap().translation.x = 1.0;
    app.update();
    assert!(close(global(&app, grandchild), Vec3::new(2.0, 2.0, -3.0)));
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 1);
}

#[test]
fn reparenting_and_orphaning() {
    let mut app = app();
    let a = app.world.spawn(Transform::from_xyz(10.0, 0.0, 0.0)).id();
    let b = app.world.spawn(Transform::from_xyz(0.0, 10.0, 0.0).with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2))).id();
    let child = app.world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(a))).id();
    let leaf = app.world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(child))).id();
    app.update();
    assert!(close(global(&app, leaf), Vec3::new(12.0, 0.0, 0.0)));

    // Reparent `child` under the rotated `b`: +X maps to +Y.
    app.world.entity_mut(child).insert(ChildOf(b));
    app.update();
    assert!(close(global(&app, child), Vec3::new(0.0, 11.0, 0.0)), "{}", global(&app, child));
    assert!(close(global(&app, leaf), Vec3::new(0.0, 12.0, 0.0)));
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 2);
    assert!(app.world.get::<Children>(a).is_none_or(|c| c.is_empty()));

    // Removing the parent link makes `child` a root again.
    app.world.entity_mut(child).remove::<ChildOf>();
    app.update();
    assert!(close(global(&app, child), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(global(&app, leaf), Vec3::new(2.0, 0.0, 0.0)));
    app.update();
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 0);
}

/// Entities whose global transform changed, as propagation listed them this frame (sorted).
fn moved(app: &App) -> Vec<Entity> {
    sorted(app.world.resource::<TransformChanges>().moved().to_vec())
}

fn sorted(mut entities: Vec<Entity>) -> Vec<Entity> {
    entities.sort();
    entities
}

#[test]
fn static_entities_are_placed_follow_parents_and_move_only_when_their_transform_is_inserted() {
    let mut app = app();
    let parent = app.world.spawn(Transform::from_xyz(5.0, 0.0, 0.0)).id();
    let free = app.world.spawn(Transform::from_xyz(0.0, 0.0, 1.0)).id();
    let fixed = app.world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), Static)).id();
    let riding = app.world.spawn((Transform::from_xyz(0.0, 1.0, 0.0), Static, ChildOf(parent))).id();
    app.update();
    assert!(close(global(&app, fixed), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(global(&app, riding), Vec3::new(5.0, 1.0, 0.0)));
    assert_eq!(moved(&app), sorted(vec![parent, free, fixed, riding]), "every spawned entity is listed as moved");
    app.update();
    assert!(moved(&app).is_empty(), "nothing moved");

    // A moving parent carries its static child.
    app.world.get_mut::<Transform>(parent).unwrap().translation.x = 6.0;
    app.update();
    assert!(close(global(&app, riding), Vec3::new(6.0, 1.0, 0.0)));
    assert_eq!(moved(&app), sorted(vec![parent, riding]));

    // Re-inserting the transform moves a static entity; re-parenting does too.
    app.world.entity_mut(fixed).insert(Transform::from_xyz(2.0, 0.0, 0.0));
    app.update();
    assert!(close(global(&app, fixed), Vec3::new(2.0, 0.0, 0.0)));
    assert_eq!(moved(&app), [fixed]);
    app.world.entity_mut(fixed).insert(ChildOf(parent));
    app.update();
    assert!(close(global(&app, fixed), Vec3::new(8.0, 0.0, 0.0)));
    assert_eq!(moved(&app), [fixed]);

    // Writing a static entity's transform in place is not seen (debug builds warn); the
    // non-static entity moves as always.
    app.world.get_mut::<Transform>(fixed).unwrap().translation.x = 3.0;
    app.world.get_mut::<Transform>(free).unwrap().translation.z = 2.0;
    app.update();
    assert!(close(global(&app, fixed), Vec3::new(8.0, 0.0, 0.0)));
    assert_eq!(moved(&app), [free]);
    // Removing Static makes the entity watched again.
    app.world.entity_mut(fixed).remove::<Static>();
    app.world.get_mut::<Transform>(fixed).unwrap().translation.x = 4.0;
    app.update();
    assert!(close(global(&app, fixed), Vec3::new(10.0, 0.0, 0.0)));
    assert_eq!(moved(&app), [fixed]);
}

#[test]
fn deep_chain_is_linear_and_correct() {
    // 2000 levels: an O(n²) propagation would still pass, but a wrong order would not.
    let mut app = app();
    let mut parent = app.world.spawn(Transform::IDENTITY).id();
    let root = parent;
    for _ in 0..2000 {
        parent = app.world.spawn((Transform::from_xyz(0.0, 0.5, 0.0), ChildOf(parent))).id();
    }
    app.update();
    assert!(close(global(&app, parent), Vec3::new(0.0, 1000.0, 0.0)));
    app.world.get_mut::<Transform>(root).unwrap().translation.x = 3.0;
    app.update();
    assert!(close(global(&app, parent), Vec3::new(3.0, 1000.0, 0.0)));
    assert_eq!(app.world.resource::<ChangedGlobals>().0, 2001);
}

#[test]
fn startup_runs_once_and_time_advances() {
    #[derive(Resource, Default)]
    struct Runs(u32);
    let mut app = app();
    app.insert_resource(Runs::default());
    app.add_systems(Startup, |mut runs: ResMut<Runs>| runs.0 += 1);
    for _ in 0..3 {
        app.update();
    }
    assert_eq!(app.world.resource::<Runs>().0, 1);
    let time = app.world.resource::<Time>();
    assert_eq!(time.frame(), 3);
    assert!((time.elapsed_secs() - 0.048).abs() < 1e-6);
}

#[test]
fn looking_at_points_forward_at_target() {
    let t = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::new(4.0, 2.0, -1.0), Vec3::Y);
    assert!(close(t.forward(), Vec3::new(3.0, 0.0, -4.0).normalize()));
    assert!((t.rotation * Vec3::Y).dot(Vec3::Y) > 0.999);
    // Degenerate: looking straight down with up = Y stays finite.
    let down = Transform::IDENTITY.looking_at(Vec3::NEG_Y, Vec3::Y);
    assert!(close(down.forward(), Vec3::NEG_Y));
    assert!(down.rotation.is_finite());
    let g = GlobalTransform::from(t);
    assert!(close(g.forward(), t.forward()));
    assert!(close(g.transform_point(Vec3::ZERO), t.translation));
}
