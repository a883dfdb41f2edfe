//! CPU cost of animation (no GPU) for 1, 100, 1,000 and 10,000 foxes (the shared `Fox.glb`: 24
//! joints, its `Walk` clip), each at its own time in the clip: one whole frame (animation,
//! transform propagation, skin matrices), and each of those parts alone as it times itself
//! ([`engine::animation::AnimationStats`] and [`engine::transform::TransformStats`], the
//! sandbox's `cpu_ms.animate`, `.propagate` and `.skin`).
//! Issue 25's target: 1,000 foxes animated in ≤ 1 ms.
//!
//! Run: `cargo bench -p engine --bench animation`

#![forbid(unsafe_code)]

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use engine::animation::{AnimationPlayer, AnimationStats};
use engine::gltf::{self, GltfAnimations};
use engine::prelude::*;
use engine::transform::TransformStats;

/// Reads the milliseconds a part of the frame reported of itself.
type PartMs = fn(&World) -> f32;

fn foxes(c: &mut Criterion) {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/assets/gltf/Fox/Fox.glb"));
    let mut scene = gltf::load(path).unwrap_or_else(|e| panic!("the shared Fox model is needed: {e}"));
    // The animation does not read the texture.
    scene.images.clear();
    for m in &mut scene.materials {
        m.base_color_texture = None;
        m.metallic_roughness_texture = None;
        m.normal_texture = None;
        m.occlusion_texture = None;
        m.emissive_texture = None;
    }
    let mut group = c.benchmark_group("animate foxes");
    for n in [1usize, 100, 1_000, 10_000] {
        let mut app = App::new();
        app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_micros(16_667)));
        // One set of assets shared by the crowd, as the sandbox's `foxes` scene spawns it.
        let prefab = scene.clone().into_prefab(&mut app.world);
        for i in 0..n {
            let root = prefab.spawn(&mut app.world);
            let walk = app.world.get::<GltfAnimations>(root).unwrap().0[1];
            let mut player = AnimationPlayer::new(walk);
            player.seek(i as f32 * 0.013);
            app.world.entity_mut(root).insert((player, Transform::from_xyz((i % 100) as f32 * 2.0, 0.0, (i / 100) as f32 * 2.0)));
        }
        app.update();
        group.bench_function(format!("frame/{n}"), |b| b.iter(|| app.update()));
        // The same frames, timed by what each part reports of itself: `animate`, transform
        // propagation and the skin matrices (the sandbox's `cpu_ms.animate`, `.propagate` and
        // `.skin`).
        let parts: [(&str, PartMs); 3] = [
            ("animate", |w| w.resource::<AnimationStats>().cpu_ms),
            ("propagate", |w| w.resource::<TransformStats>().cpu_ms),
            ("skin", |w| w.resource::<AnimationStats>().skin_cpu_ms),
        ];
        for (part, ms) in parts {
            group.bench_function(format!("{part}/{n}"), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            app.update();
                            Duration::from_secs_f32(ms(&app.world) * 1e-3)
                        })
                        .sum()
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, foxes);
criterion_main!(benches);
