//! The integration tests: one test binary with a module per area, as cargo's and
//! rust-analyzer's own suites are laid out (one link instead of one per area). Run them with
//! `cargo nextest run -p tests` (what `scripts/test.sh` does: every test in a process of its own,
//! both cores busy until the last test) or `cargo test -p tests`.
//!
//! What each area checks is listed in `docs/TESTING.md`; the tests that were merged or cut to
//! keep the suite within its time, and the test that covers what they checked, are listed at the
//! end of that page.
//!
//! Two tests change their whole process (`no_device` hides the Vulkan drivers, `soak` counts the
//! heap): each runs its body in a child process of this binary ([`tests::in_own_process`]), so
//! the other tests of a `cargo test` run, which share one process, never see it.

#![forbid(unsafe_code)]

mod antialiasing;
mod bad_input;
mod brdf;
mod clustered;
mod culling;
mod decals;
mod display;
mod ecs;
mod environment;
mod fuzz;
mod gameplay;
mod gltf_textures;
mod hostile;
mod lights;
mod limits;
mod lod;
mod memory;
mod motion;
mod no_device;
mod occlusion;
mod particles;
mod pipelines;
mod reflections;
mod reliability;
mod scenes;
mod skinning;
mod soak;
mod transparency;

/// Counts the heap, for the soak's memory check (`soak`, which runs in a process of its own so
/// that only its own allocations are counted). Every test of the binary allocates through it: an
/// atomic add per allocation.
#[global_allocator]
static ALLOCATOR: cap::Cap<std::alloc::System> = cap::Cap::new(std::alloc::System, usize::MAX);
