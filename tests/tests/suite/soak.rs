//! The soak in CI: a short deterministic run of random gameplay, configuration switches,
//! resizes and tier changes under validation with synchronization validation (see
//! `sandbox::soak`). Longer runs: `cargo run --release -p sandbox -- --soak --frames 10000`.
//! It runs in a process of its own, so that the heap it measures is its own.

use sandbox::soak::{SoakConfig, run};

#[test]
fn random_gameplay_stays_valid_finite_and_gives_its_memory_back() {
    if !tests::in_own_process(module_path!(), "random_gameplay_stays_valid_finite_and_gives_its_memory_back", &[]) {
        return;
    }
    let report =
        run(&SoakConfig { frames: 800, cycles: 4, heap_bytes: Some(|| crate::ALLOCATOR.allocated() as u64), ..Default::default() })
            .expect("the soak runs");
    println!("{}", serde_json::to_string_pretty(&report).unwrap());
    assert!(report.cycles.iter().all(|c| c.heap_after > 0), "the heap was counted");
    let failures = report.failures();
    assert!(failures.is_empty(), "the soak failed:\n{}", failures.join("\n"));
    let g = report.gameplay;
    assert!(g.decals_spawned > 1000 && g.lights_spawned > 100 && g.instances_spawned > 100 && g.assets_removed > 8, "{g:?}");
    let s = report.switches;
    assert!(s.pipeline > 10 && s.decal_method > 10 && s.light_method > 10 && s.debug_view > 6 && s.resize > 5 && s.tier >= 3, "{s:?}");
    assert!(s.aa > 5, "anti-aliasing switched: {s:?}");
    assert!(s.environment > 5 && s.display > 5, "environments and display transforms switched: {s:?}");
    let tiers: std::collections::HashSet<_> = report.cycles.iter().map(|c| c.tier).collect();
    assert!(tiers.len() >= 2, "cycles ran on more than one tier: {tiers:?}");
}
