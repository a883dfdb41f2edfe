//! CPU cost of decal extraction (no GPU): what a frame costs on the CPU when 0 %, 1 % or 100 %
//! of 100,000 decals moved, and what spawning 1,000 or 10,000 decals in one frame costs.
//!
//! Each measured frame is `App::update()` (transform propagation, lifetimes, every extraction
//! system) followed by draining the mirror's dirty lists the way the GPU uploader does (sorting
//! and clearing them; the copies themselves are GPU work and not measured here).
//!
//! Run: `cargo bench -p plugins --bench extraction`

#![forbid(unsafe_code)]

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::{RenderMirror, RenderPlugin, RenderSettings};

fn app_with_decals(n: usize) -> (App, Vec<Entity>, Handle<DecalMaterial>) {
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_millis(16)));
    app.add_plugins(RenderPlugin::new(RenderSettings::default()));
    let material = app.world.resource_mut::<Assets<DecalMaterial>>().add(DecalMaterial::default());
    let side = (n as f32).sqrt().ceil() as usize;
    let batch: Vec<_> = (0..n)
        .map(|i| {
            let (x, z) = ((i % side) as f32, (i / side) as f32);
            (Decal::new(material), Transform::from_xyz(x, 0.0, z).with_scale(Vec3::splat(0.5)))
        })
        .collect();
    let entities: Vec<Entity> = app.world.spawn_batch(batch).collect();
    frame(&mut app);
    (app, entities, material)
}

fn frame(app: &mut App) {
    app.update();
    app.world.resource_mut::<RenderMirror>().0.clear_dirty();
}

fn moved_per_frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("extract 100k decals");
    for percent in [0usize, 1, 100] {
        let (mut app, entities, _) = app_with_decals(100_000);
        let moved = entities.len() * percent / 100;
        let mut tick = 0.0f32;
        group.bench_function(format!("{percent}% moved"), |b| {
            b.iter(|| {
                tick += 0.001;
                for &e in &entities[..moved] {
                    app.world.get_mut::<Transform>(e).unwrap().translation.y = tick;
                }
                frame(&mut app);
            })
        });
    }
    group.finish();
}

fn spawn_in_one_frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("spawn decals in one frame");
    group.sample_size(20);
    for n in [1_000usize, 10_000] {
        let (mut app, _, material) = app_with_decals(0);
        group.bench_function(format!("{n}"), |b| {
            b.iter_batched(
                || (0..n).map(|i| (Decal::new(material), Transform::from_xyz(i as f32, 0.0, 0.0))).collect::<Vec<_>>(),
                |batch| {
                    let spawned: Vec<Entity> = app.world.spawn_batch(batch).collect();
                    frame(&mut app);
                    // Despawn outside the next measurement's spawn, keeping the world the same size.
                    for e in spawned {
                        app.world.despawn(e);
                    }
                    frame(&mut app);
                },
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, moved_per_frame, spawn_in_one_frame);
criterion_main!(benches);
