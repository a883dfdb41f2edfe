//! The particle emitters as the scene mirror keeps them ([`Emitters`], `crate::particles` moves
//! and draws their particles): a slot per emitter, what each starts this frame, and the motion
//! step the GPU takes, repeated on the CPU ([`step`]) as the reference that tests hold the GPU
//! to.

use glam::Vec3;

use crate::layout::GpuEmission;
use crate::layout::GpuEmitter;

/// The ring of decals that landing particles leave (`crate::particles`), as the decal passes
/// enumerate it after the scene's decals: its places (`GPU_DECAL` slots), the graph resource
/// holding its records and boxes, and, where decals are traced, its own acceleration structures
/// (a TLAS whose instances, of custom index 1, are its segments' BLASes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalRing {
    /// Places of the ring.
    pub room: u32,
    /// The graph resource holding its records and boxes.
    pub res: crate::graph::ResourceId,
    /// Its TLAS and BLAS resources, on devices with acceleration structures once built.
    pub traced: Option<[crate::graph::ResourceId; 2]>,
}

/// One emitter: its parameters as the GPU reads them, how many particles a second it starts,
/// and a burst to start once.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Emitter {
    /// The parameters every particle it starts follows (its transform included).
    pub record: GpuEmitter,
    /// Particles started a second (0: bursts only).
    pub rate: f32,
    /// Particles to start at once, in the next frame (a write with a burst starts it again).
    pub burst: u32,
}

#[derive(Clone, Copy, Debug)]
struct Slot {
    emitter: Emitter,
    /// Fractional particles owed by the rate.
    owed: f32,
    /// The burst not yet started.
    burst: u32,
    /// Seconds its longest-lived particle has left after this frame's step, as the GPU ages it
    /// (a particle takes its first step in the frame it is born), with [`LIFE_MARGIN`].
    alive_for: f32,
    /// Removed: it starts nothing more, and its slot is reused once `alive_for` has run out.
    retiring: bool,
}

/// Seconds added to every life the CPU counts down, so that float rounding between its
/// countdown and the GPU's ageing never lets it stop the particle passes, or reuse a slot,
/// while the GPU still holds a living particle.
const LIFE_MARGIN: f32 = 1e-3;

/// The emitters, by slot, and what they start each frame. A removed emitter starts nothing more
/// but keeps its slot (its particles still read its parameters) until the longest life it gives
/// has passed.
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    slots: Vec<Option<Slot>>,
    /// Set when a record changed: the table is uploaded whole (it is small and rarely changes).
    dirty: bool,
    /// Some particle lived before this frame's step (so the step must run).
    alive_before: bool,
    live: usize,
    /// Some emitter has left decals where its particles land (`GpuEmitter::decal_material`):
    /// from then on the decal ring is enumerated with the scene's decals.
    leaves_decals: bool,
}

impl Emitter {
    /// Whether its particles leave decals where they land: a decal material and a size (a
    /// zeroed record leaves none).
    pub fn leaves_decals(&self) -> bool {
        self.record.decal_material != crate::layout::NO_DECAL && self.record.decal_size > 0.0
    }
}

impl Emitters {
    /// Adds an emitter and returns its slot.
    pub fn insert(&mut self, emitter: Emitter) -> u32 {
        let slot = Slot { emitter, owed: 0.0, burst: emitter.burst, alive_for: 0.0, retiring: false };
        self.dirty = true;
        self.leaves_decals |= emitter.leaves_decals();
        self.live += 1;
        match self.slots.iter().position(Option::is_none) {
            Some(i) => {
                self.slots[i] = Some(slot);
                i as u32
            }
            None => {
                self.slots.push(Some(slot));
                self.slots.len() as u32 - 1
            }
        }
    }

    /// Replaces a live emitter's parameters; its burst (if any) starts again.
    pub fn write(&mut self, slot: u32, emitter: Emitter) {
        if let Some(Some(s)) = self.slots.get_mut(slot as usize) {
            if s.emitter.record != emitter.record {
                self.dirty = true;
            }
            self.leaves_decals |= emitter.leaves_decals();
            s.emitter = emitter;
            s.burst = emitter.burst;
        }
    }

    /// Moves a live emitter (its transform alone), without starting its burst again.
    pub fn set_transform(&mut self, slot: u32, transform: glam::Mat4) {
        if let Some(Some(s)) = self.slots.get_mut(slot as usize)
            && !s.retiring
            && s.emitter.record.transform != transform
        {
            s.emitter.record.transform = transform;
            self.dirty = true;
        }
    }

    /// A live emitter's parameters.
    pub fn record(&self, slot: u32) -> Option<&GpuEmitter> {
        self.slots.get(slot as usize)?.as_ref().filter(|s| !s.retiring).map(|s| &s.emitter.record)
    }

    /// Points a live emitter at another sprite texture (its image was uploaded or replaced),
    /// without starting its burst again.
    pub fn set_texture(&mut self, slot: u32, texture: u32) {
        if let Some(Some(s)) = self.slots.get_mut(slot as usize)
            && !s.retiring
            && s.emitter.record.texture != texture
        {
            s.emitter.record.texture = texture;
            self.dirty = true;
        }
    }

    /// Removes an emitter: it starts nothing more; its slot is reused once its particles are gone.
    pub fn remove(&mut self, slot: u32) {
        if let Some(Some(s)) = self.slots.get_mut(slot as usize)
            && !s.retiring
        {
            s.retiring = true;
            s.burst = 0;
            self.live -= 1;
        }
    }

    /// Live emitters (not counting removed ones whose particles still live).
    pub fn len(&self) -> usize {
        self.live
    }

    /// Whether no emitter is live.
    pub fn is_empty(&self) -> bool {
        self.live == 0
    }

    /// Whether some emitter has left decals where its particles land: from then on the ring of
    /// decals they leave is enumerated with the scene's decals (`crate::particles`).
    pub fn leaves_decals(&self) -> bool {
        self.leaves_decals
    }

    /// The decal material slots the emitters' particles leave (live and removed emitters alike).
    pub fn decal_materials(&self) -> impl Iterator<Item = u32> + '_ {
        self.slots.iter().flatten().filter(|s| s.emitter.leaves_decals()).map(|s| s.emitter.record.decal_material)
    }

    /// Slots the table spans (the GPU table's length).
    pub fn slot_count(&self) -> u32 {
        self.slots.len() as u32
    }

    /// After [`Emitters::advance`]: whether this frame has particles to step (some lived before
    /// it) or to start; the particle passes run only then.
    pub fn active(&self) -> bool {
        self.alive_before || self.slots.iter().flatten().any(|s| !s.retiring && (s.emitter.rate > 0.0 || s.burst > 0))
    }

    /// Takes the records for upload when any changed (`None` when none did).
    pub fn take_dirty(&mut self) -> Option<impl Iterator<Item = GpuEmitter> + '_> {
        if !std::mem::take(&mut self.dirty) {
            return None;
        }
        Some(self.slots.iter().map(|s| s.map_or(GpuEmitter::default(), |s| s.emitter.record)))
    }

    /// Marks every record for upload (the GPU table was replaced).
    pub fn mark_all_dirty(&mut self) {
        self.dirty = true;
    }

    /// Advances the emitters by `delta` seconds: the jobs of the particles each starts now
    /// (pushed to `jobs`, their invocations numbered from 0; `seed` varies them from frame to
    /// frame; at most `room` particles in all, the pool's size: what is past it would be dropped
    /// anyway), retiring removed emitters whose particles are gone. Each slot counts down the
    /// life its longest-lived particle has left, as the GPU ages it, so that the passes keep
    /// running and the slot stays reserved while any of them lives (whatever `write` later does
    /// to the emitter's lifetimes). Returns the particles started and those cut by `room`.
    pub fn advance(&mut self, delta: f32, seed: u32, room: u32, jobs: &mut Vec<GpuEmission>) -> (u32, u64) {
        jobs.clear();
        let delta = delta.max(0.0);
        let (mut first, mut cut) = (0u32, 0u64);
        self.alive_before = false;
        for (i, entry) in self.slots.iter_mut().enumerate() {
            let Some(s) = entry else { continue };
            // Particles that lived before this frame take its step (and may die in it).
            self.alive_before |= s.alive_for > 0.0;
            s.alive_for = (s.alive_for - delta).max(0.0);
            if s.retiring {
                if s.alive_for <= 0.0 {
                    *entry = None;
                    self.dirty = true;
                }
                continue;
            }
            s.owed += s.emitter.rate.max(0.0) * delta;
            let from_rate = s.owed.floor();
            s.owed -= from_rate;
            let wanted = (from_rate.min(u32::MAX as f32) as u32).saturating_add(std::mem::take(&mut s.burst));
            let count = wanted.min(room - first);
            cut += (wanted - count) as u64;
            if count == 0 {
                continue;
            }
            let seed = seed.wrapping_mul(0x9E37_79B9).wrapping_add(i as u32).wrapping_mul(0x85EB_CA6B);
            jobs.push(GpuEmission { emitter: i as u32, first, count, seed });
            first += count;
            // Born this frame, they take this frame's step too.
            let r = &s.emitter.record;
            s.alive_for = s.alive_for.max(r.lifetime_max.max(r.lifetime_min) - delta + LIFE_MARGIN);
        }
        while self.slots.last().is_some_and(Option::is_none) {
            self.slots.pop();
        }
        (first, cut)
    }
}

/// One step of the particles' motion, `dt` seconds: the velocity takes the acceleration and
/// loses its drag, then the position moves by the new velocity (semi-implicit Euler). The GPU's
/// `particle_step` (`shaders/include/particles.glsl`) is the same expression.
pub fn step(position: &mut Vec3, velocity: &mut Vec3, acceleration: Vec3, drag: f32, dt: f32) {
    *velocity = (*velocity + acceleration * dt) * (-drag * dt).exp();
    *position += *velocity * dt;
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: u32 = 1 << 16;

    fn emitter(rate: f32, burst: u32, life: f32) -> Emitter {
        let record = GpuEmitter { lifetime_min: life, lifetime_max: life, ..Default::default() };
        Emitter { record, rate, burst }
    }

    #[test]
    fn rates_accumulate_and_bursts_start_once() {
        let mut e = Emitters::default();
        let a = e.insert(emitter(30.0, 5, 1.0));
        let mut jobs = Vec::new();
        // 30 a second over 1/60 s is half a particle: the burst alone, then one every other frame.
        assert_eq!(e.advance(1.0 / 60.0, 1, ROOM, &mut jobs).0, 5);
        assert_eq!(e.advance(1.0 / 60.0, 2, ROOM, &mut jobs).0, 1);
        assert_eq!(jobs, [GpuEmission { emitter: a, first: 0, count: 1, seed: jobs[0].seed }]);
        assert_eq!(e.advance(1.0 / 60.0, 3, ROOM, &mut jobs).0, 0);
        let total: u32 = (0..57).map(|f| e.advance(1.0 / 60.0, f, ROOM, &mut jobs).0).sum();
        assert!((28..=29).contains(&total), "{total}");
        // Writing it again with a burst starts the burst again.
        e.write(a, emitter(0.0, 3, 1.0));
        assert_eq!(e.advance(1.0 / 60.0, 9, ROOM, &mut jobs).0, 3);
    }

    #[test]
    fn jobs_number_their_invocations_in_order() {
        let mut e = Emitters::default();
        e.insert(emitter(0.0, 4, 1.0));
        e.insert(emitter(0.0, 0, 1.0));
        e.insert(emitter(0.0, 6, 1.0));
        let mut jobs = Vec::new();
        assert_eq!(e.advance(0.016, 7, ROOM, &mut jobs).0, 10);
        assert_eq!(jobs.iter().map(|j| (j.emitter, j.first, j.count)).collect::<Vec<_>>(), [(0, 0, 4), (2, 4, 6)]);
        assert_ne!(jobs[0].seed, jobs[1].seed);
    }

    #[test]
    fn removed_emitters_keep_their_slot_while_their_particles_live() {
        let mut e = Emitters::default();
        let a = e.insert(emitter(0.0, 1, 0.5));
        let mut jobs = Vec::new();
        e.advance(0.1, 0, ROOM, &mut jobs);
        e.remove(a);
        assert!(e.is_empty());
        e.advance(0.1, 0, ROOM, &mut jobs);
        assert!(e.active(), "its particle lives 0.5 s");
        let b = e.insert(emitter(0.0, 0, 1.0));
        assert_ne!(a, b, "the slot is still read by the removed emitter's particles");
        for _ in 0..6 {
            e.advance(0.1, 0, ROOM, &mut jobs);
        }
        assert_eq!(e.insert(emitter(0.0, 0, 1.0)), a, "free once its particles are gone");
    }

    #[test]
    fn the_countdown_follows_the_gpus_ageing_and_outlasts_a_shortened_life() {
        let mut e = Emitters::default();
        let a = e.insert(emitter(0.0, 1, 0.05));
        let mut jobs = Vec::new();
        // Born and stepped in frame 0 (age 0.02), stepped in frames 1 and 2 (0.04, 0.06: dead
        // in frame 2's step): the passes run in all three, not in frame 3.
        let active: Vec<bool> = (0..4).map(|f| e.advance(0.02, f, ROOM, &mut jobs).0 > 0 || e.active()).collect();
        assert_eq!(active, [true, true, true, false]);
        // A slot's reservation follows the lives its particles were given, not a later write.
        e.write(a, emitter(0.0, 1, 1.0));
        e.advance(0.02, 9, ROOM, &mut jobs);
        e.write(a, emitter(0.0, 0, 0.01));
        e.remove(a);
        for _ in 0..45 {
            e.advance(0.02, 0, ROOM, &mut jobs);
        }
        assert_ne!(e.insert(emitter(0.0, 0, 1.0)), a, "its 1 s particle still lives");
    }

    #[test]
    fn a_frame_starts_no_more_than_the_pool_holds() {
        let mut e = Emitters::default();
        e.insert(emitter(0.0, 700, 1.0));
        e.insert(emitter(0.0, 700, 1.0));
        let mut jobs = Vec::new();
        assert_eq!(e.advance(0.016, 0, 1000, &mut jobs), (1000, 400));
        assert_eq!(jobs.iter().map(|j| j.count).collect::<Vec<_>>(), [700, 300]);
    }

    #[test]
    fn the_step_follows_the_closed_form_without_drag() {
        // Semi-implicit Euler under constant acceleration: x_n = x0 + v0·n·dt + a·dt²·n(n+1)/2.
        let (mut p, mut v) = (Vec3::ZERO, Vec3::new(1.0, 2.0, 0.0));
        let a = Vec3::new(0.0, -9.81, 0.0);
        let dt = 0.02;
        for _ in 0..50 {
            step(&mut p, &mut v, a, 0.0, dt);
        }
        let n = 50.0;
        let expected = Vec3::new(1.0, 2.0, 0.0) * n * dt + a * dt * dt * n * (n + 1.0) / 2.0;
        assert!((p - expected).length() < 1e-4, "{p} against {expected}");
        // Drag takes e^−drag·dt of the speed each step.
        let (mut p, mut v) = (Vec3::ZERO, Vec3::X);
        step(&mut p, &mut v, Vec3::ZERO, 2.0, 0.5);
        assert!((v.x - (-1.0f32).exp()).abs() < 1e-6);
    }
}
