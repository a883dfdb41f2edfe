//! CPU cost of animation (no GPU) for 1, 100, 1,000 and 10,000 foxes (the shared `Fox.glb`: 24
//! joints, its `Walk` clip), each at its own time in the clip: one whole frame (animation,
//! transform propagation, skin matrices), and each of those parts alone as it times itself
//! ([`engine::animation::AnimationStats`] and [`engine::transform::TransformStats`], the
//! sandbox's `cpu_ms.animate`, `.propagate` and `.skin`).
//! Issue 25's target: 1,000 foxes animated in ≤ 1 ms.
//!
//! `frame_budget/N`: the same frame with the animation budget on
//! ([`engine::animation::AnimationBudget`]), seen as the sandbox's `foxes` scene sees the crowd
//! (from above, all of it in a 1920×1080 view, each fox a few pixels): most foxes sample every
//! fourth frame; `animate_budget/N`, `propagate_budget/N` and `skin_budget/N` its parts.
//!
//! The crowd is spawned as the glTF prefab spawns it by default: every skin a
//! [`engine::animation::CompactSkeleton`], posed in one pass that also places its bones'
//! entities. `frame_bones/N` and its parts: the same crowd with its bones posed as entities
//! (animation, propagation, then the skin matrices from the bones); `frame_unplaced/N`: compact,
//! its bones' entities left unplaced ([`engine::animation::UnplacedBones`], as the sandbox spawns
//! its crowds).
//!
//! Run: `cargo bench -p engine --bench animation`

#![forbid(unsafe_code)]

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use engine::animation::{AnimationBudget, AnimationPlayer, AnimationStats};
use engine::camera::Camera;
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
        // The prefab's default (compact skeletons placing their bones), bones as entities, and
        // compact skeletons leaving their bones unplaced: one rig shared by all.
        for (compact, unplaced, suffix) in [(true, false, ""), (false, false, "_bones"), (true, true, "_unplaced")] {
            let mut app = App::new();
            app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_micros(16_667)));
            // One set of assets shared by the crowd, as the sandbox's `foxes` scene spawns it.
            let mut prefab = scene.clone().into_prefab(&mut app.world);
            (prefab.compact_skeletons, prefab.unplaced_bones) = (compact, unplaced);
            for i in 0..n {
                let root = prefab.spawn(&mut app.world);
                let walk = app.world.get::<GltfAnimations>(root).unwrap().0[1];
                let mut player = AnimationPlayer::new(walk);
                player.seek(i as f32 * 0.013);
                // The file is in centimetres: a metre-long fox every 2 m, as in the sandbox.
                let at = Transform::from_xyz((i % 100) as f32 * 2.0, 0.0, (i / 100) as f32 * 2.0).with_scale(Vec3::splat(0.01));
                app.world.entity_mut(root).insert((player, at));
            }
            // The sandbox's `foxes` camera: above the crowd's centre, seeing all of it.
            let half = (n.min(100) as f32 - 1.0).max(1.0);
            let centre = Vec3::new(half, 0.0, (n.div_ceil(100) as f32 - 1.0).max(0.0));
            let distance = 3.0 + half * 1.6;
            let eye = centre + Vec3::new(0.0, distance * 0.6, distance);
            app.world.spawn((Camera::default(), Transform::from_translation(eye).looking_at(centre, Vec3::Y)));
            app.update();
            frames(&mut group, &mut app, n, suffix);
        }
    }
    group.finish();
}

/// `frame{suffix}/N` and `frame{suffix}_budget/N`, then each part alone as it times itself
/// (`animate{suffix}/N`, ...), without the budget and with it.
fn frames(group: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>, app: &mut App, n: usize, suffix: &str) {
    group.bench_function(format!("frame{suffix}/{n}"), |b| b.iter(|| app.update()));
    *app.world.resource_mut::<AnimationBudget>() =
        AnimationBudget { enabled: true, viewport: Vec2::new(1920.0, 1080.0), ..Default::default() };
    app.update();
    group.bench_function(format!("frame{suffix}_budget/{n}"), |b| b.iter(|| app.update()));
    // The same frames, timed by what each part reports of itself: `animate`, transform
    // propagation and the skin matrices (the sandbox's `cpu_ms.animate`, `.propagate` and
    // `.skin`), without the budget and with it (`animate_budget/N`, ...).
    let parts: [(&str, PartMs); 3] = [
        ("animate", |w| w.resource::<AnimationStats>().cpu_ms),
        ("propagate", |w| w.resource::<TransformStats>().cpu_ms),
        ("skin", |w| w.resource::<AnimationStats>().skin_cpu_ms),
    ];
    for budget in [false, true] {
        app.world.resource_mut::<AnimationBudget>().enabled = budget;
        app.update();
        for (part, ms) in parts {
            let name = if budget { format!("{part}{suffix}_budget/{n}") } else { format!("{part}{suffix}/{n}") };
            group.bench_function(name, |b| {
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
}

criterion_group!(benches, foxes);
criterion_main!(benches);
