//! Frame time: the [`Time`] resource, advanced by [`crate::app::App::update`] once per frame.
//!
//! Windowed runs use the real clock; headless runs and tests set a fixed step so that every
//! run of the same frames produces the same simulation.

use std::time::{Duration, Instant};

use bevy_ecs::resource::Resource;

/// Time since startup and since the previous frame.
#[derive(Resource, Clone, Debug, Default)]
pub struct Time {
    fixed_step: Option<Duration>,
    last_instant: Option<Instant>,
    delta: Duration,
    elapsed: Duration,
    frame: u64,
    update_started: Option<Instant>,
}

impl Time {
    /// A clock that advances by `step` every frame instead of following the real clock.
    pub fn fixed(step: Duration) -> Self {
        Time { fixed_step: Some(step), ..Default::default() }
    }

    /// Duration of the current frame (zero during the first real-clock frame).
    pub fn delta(&self) -> Duration {
        self.delta
    }

    /// [`Time::delta`] in seconds.
    pub fn delta_secs(&self) -> f32 {
        self.delta.as_secs_f32()
    }

    /// Seconds elapsed up to the current frame (sum of all deltas).
    pub fn elapsed_secs(&self) -> f32 {
        self.elapsed.as_secs_f32()
    }

    /// Sum of all deltas as a [`Duration`].
    pub fn elapsed(&self) -> Duration {
        self.elapsed
    }

    /// The number of frames advanced so far: 1 during the first frame's schedules.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// The wall-clock instant at which the current frame's update began (also with a fixed
    /// step): for measuring the CPU time a frame took, never for simulation.
    pub fn update_started(&self) -> Option<Instant> {
        self.update_started
    }

    /// Sets (`Some`) or clears (`None`, real clock) the fixed step.
    pub fn set_fixed_step(&mut self, step: Option<Duration>) {
        self.fixed_step = step;
        self.last_instant = None;
    }

    /// The fixed step, if one is set.
    pub fn fixed_step(&self) -> Option<Duration> {
        self.fixed_step
    }

    /// Starts a new frame: measures (or, with a fixed step, assumes) its delta.
    pub fn advance(&mut self) {
        let now = Instant::now();
        self.update_started = Some(now);
        self.delta = match (self.fixed_step, self.last_instant) {
            (Some(step), _) => step,
            (None, Some(last)) => now.saturating_duration_since(last),
            (None, None) => Duration::ZERO,
        };
        self.last_instant = Some(now);
        self.elapsed += self.delta;
        self.frame += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_step_accumulates() {
        let mut time = Time::default();
        time.set_fixed_step(Some(Duration::from_millis(250)));
        for _ in 0..4 {
            time.advance();
        }
        assert_eq!(time.frame(), 4);
        assert_eq!(time.delta(), Duration::from_millis(250));
        assert!((time.elapsed_secs() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn real_clock_first_frame_is_zero() {
        let mut time = Time::default();
        time.advance();
        assert_eq!(time.delta(), Duration::ZERO);
        assert_eq!(time.frame(), 1);
    }
}
