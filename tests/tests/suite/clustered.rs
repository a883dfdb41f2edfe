//! Clustered decals (no ray tracing at all) on lavapipe with the tier forced to `none`: the cluster
//! buffer grows when a frame needs more room than it has, without losing a decal once it has
//! grown, and decals the camera cannot see cost no cluster entries. (Every decal test of
//! `decals.rs` also runs through clustered decals in each pipeline, and `pipelines.rs` compares
//! clustered images with the ray-traced ones.)

use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{RenderSettings, RenderStats};
use render::stats::DecalClusterStats;
use render::{DebugView, DecalMethod, PipelineKind, RendererSettings, Tier};
use tests::{TopDownView, assert_no_validation_errors, gpu_app_with, renderer};

const SIZE: (u32, u32) = (128, 96);

fn clustered_app(capacity: u32) -> (App, TopDownView, Handle<DecalMaterial>) {
    let device = render::DeviceSettings { max_tier: Tier::NoRayTracing, ..Default::default() };
    // Deferred: its decal pass walks the lists and counts what it tested and applied per pixel
    // (forward shading walks them itself and counts nothing).
    let settings = RenderSettings {
        debug_view: DebugView::Albedo,
        decal_method: DecalMethod::Clustered,
        pipeline: PipelineKind::Deferred,
        ..Default::default()
    };
    let mut app =
        gpu_app_with(SIZE.0, SIZE.1, settings, &RendererSettings { device, decal_cluster_capacity: capacity, ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.5, 0.5, 0.5, 1.0), 0.0, 0.8));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    let view = TopDownView::new(4.0, SIZE);
    view.spawn(&mut app.world);
    let red = app
        .world
        .resource_mut::<Assets<DecalMaterial>>()
        .add(DecalMaterial { base_color: Some(Vec4::new(1.0, 0.0, 0.0, 1.0)), ..Default::default() });
    (app, view, red)
}

/// A decal `size` metres square on the ground at `centre`, projecting down.
fn ground_decal(centre: Vec3, size: f32) -> Transform {
    Transform::from_translation(centre).looking_at(centre - Vec3::Y, Vec3::NEG_Z).with_scale(Vec3::new(size, size, 1.0))
}

fn cluster_stats(app: &App) -> DecalClusterStats {
    app.world.resource::<RenderStats>().last.clusters
}

#[test]
fn the_cluster_buffer_grows_when_a_cluster_holds_more_decals_than_it_has_room_for() {
    // Room for 64 entries; 100 small decals in a 10 × 10 grid inside one 32-pixel tile (about
    // 1.24 m of ground here: the tile of pixels 64–95 × 32–63, around x = 0.62 m, z = 0), so one
    // cluster alone needs 100.
    let (mut app, view, red) = clustered_app(64);
    let centres: Vec<Vec3> = (0..100).map(|i| Vec3::new(0.17 + (i % 10) as f32 * 0.1, 0.0, -0.45 + (i / 10) as f32 * 0.1)).collect();
    for &c in &centres {
        app.world.spawn((Decal::new(red), ground_decal(c, 0.06)));
    }
    let mut seen = Vec::new();
    for _ in 0..6 {
        app.update();
        seen.push(cluster_stats(&app));
    }
    assert_no_validation_errors(&mut app);
    assert_eq!(seen[0].capacity, 64, "the first frame has the initial room: {:?}", seen[0]);
    let overflowed = seen.iter().find(|s| s.measured_frame != u64::MAX).expect("statistics come back within a few frames");
    assert!(overflowed.dropped > 0 && overflowed.entries >= 100, "the first measured frame lacked room and says so: {overflowed:?}");
    let last = *seen.last().unwrap();
    assert!(last.grows >= 1 && last.capacity >= last.entries, "the buffer grew: {last:?}");
    assert_eq!(last.dropped, 0, "nothing is dropped once it has grown: {last:?}");
    assert!(last.max_per_cluster >= 100, "one cluster holds every decal: {last:?}");

    let albedo = renderer(&mut app).read_hdr().unwrap();
    for c in &centres {
        let (px, py) = view.pixel_of(*c);
        let got = albedo[(py * SIZE.0 + px) as usize];
        assert!(got[0] > 0.9 && got[1] < 0.1, "the decal at {c} shows after the growth: {got:?}");
    }
    assert!(last.limit >= last.capacity, "the room stays under its memory ceiling: {last:?}");

    // All but one decal go: a second later the room is back to the initial 64 entries.
    let decals: Vec<Entity> = app.world.query_filtered::<Entity, With<Decal>>().iter(&app.world).skip(1).collect();
    for e in decals {
        app.world.despawn(e);
    }
    for _ in 0..render::gpu::upload::SHRINK_AFTER_FRAMES + 6 {
        app.update();
    }
    let after = cluster_stats(&app);
    assert_eq!(after.capacity, 64, "the cluster room returned after the despawn: {after:?}");
    assert!(after.shrinks > last.shrinks && after.dropped == 0, "{after:?}");

    // No decal method: the room is held, and shown, for a second; then released, with what it
    // measured.
    app.world.resource_mut::<RenderSettings>().decal_method = DecalMethod::Off;
    for _ in 0..render::gpu::upload::SHRINK_AFTER_FRAMES - 2 {
        app.update();
    }
    let unused = cluster_stats(&app);
    assert_eq!((unused.capacity, unused.shrinks), (64, after.shrinks), "held and shown while unused: {unused:?}");
    for _ in 0..4 {
        app.update();
    }
    let released = cluster_stats(&app);
    assert!(released.shrinks > after.shrinks, "released a second after binning stopped: {released:?}");
    assert_eq!(
        (released.capacity, released.clusters, released.entries, released.measured_frame),
        (0, 0, 0, u64::MAX),
        "a released buffer holds no room and forgets what it measured: {released:?}"
    );
    assert_no_validation_errors(&mut app);
}

#[test]
fn decals_behind_the_camera_or_off_screen_cost_no_cluster_entries() {
    let (mut app, view, red) = clustered_app(1024);
    // The camera is 4 m above the ground looking down: boxes above it are behind it, boxes 40 m
    // away are off screen, and boxes 3 m to its side at its own height reach behind it with the
    // part in front far outside the view (the binning once gave such a box the whole screen).
    // Boxes hanging 2 m above the ground, in view, reach no depth the screen shows: the tiles'
    // depth bounds keep them out of every cluster.
    for i in 0..20 {
        let x = i as f32 * 0.2;
        app.world.spawn((Decal::new(red), ground_decal(Vec3::new(x - 2.0, 2.0, 0.5), 1.0)));
        app.world.spawn((Decal::new(red), ground_decal(Vec3::new(x, 6.0, 0.0), 1.0)));
        app.world.spawn((Decal::new(red), ground_decal(Vec3::new(3.0, 4.0, x - 2.0), 1.0)));
        app.world.spawn((Decal::new(red), ground_decal(Vec3::new(40.0 + x, 0.0, 0.0), 1.0)));
        app.world.spawn((Decal::new(red), ground_decal(Vec3::new(0.0, 0.0, -40.0 - x), 1.0)));
    }
    let measured = |app: &mut App| {
        for _ in 0..4 {
            app.update();
        }
        let s = cluster_stats(app);
        assert!(s.measured_frame != u64::MAX, "statistics came back: {s:?}");
        s
    };
    let hidden = measured(&mut app);
    assert_eq!(app.world.resource::<RenderStats>().last.decals, 100);
    assert_eq!((hidden.entries, hidden.clusters_used, hidden.applied), (0, 0, 0), "100 decals on no surface cost nothing: {hidden:?}");

    // One decal in view: a few entries (the clusters its box touches), and it shows.
    app.world.spawn((Decal::new(red), ground_decal(Vec3::ZERO, 0.5)));
    let seen = measured(&mut app);
    assert!(seen.entries >= 1 && seen.entries <= 8, "one visible decal, a few clusters: {seen:?}");
    assert!(seen.applied > 0, "{seen:?}");
    let albedo = renderer(&mut app).read_hdr().unwrap();
    let (px, py) = view.pixel_of(Vec3::ZERO);
    assert!(albedo[(py * SIZE.0 + px) as usize][0] > 0.9);
    assert_no_validation_errors(&mut app);
}
