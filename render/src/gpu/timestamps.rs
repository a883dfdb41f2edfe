//! Per-pass GPU times from timestamp queries.
//!
//! Each frame in flight owns a query pool. Passes share their boundaries: one timestamp before
//! the first pass and one after each, all at `ALL_COMMANDS` (written once everything recorded
//! before it has finished), so the end of one pass is the start of the next, as a timestamp at
//! the next pass's start would read. That is one write a pass instead of two (in a deferred frame
//! of 34 passes, the 68 writes cost its recording about 11 µs on the lent H100's host).
//! Results are read when the frame's slot comes round again (its fence has passed), so reading
//! never stalls.

use ash::vk;

use crate::RenderError;
use crate::gpu::commands::Recorder;
use crate::gpu::device::GpuContext;

/// Most passes one frame can time (a deferred frame with two-phase culling, shadows, decals and
/// glass records about 20; a frame that filters a new environment about 20 more).
pub const MAX_PASSES: usize = 64;

/// GPU milliseconds per pass for one frame, in recording order; no heap allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassTimes {
    entries: [(&'static str, f32); MAX_PASSES],
    len: usize,
    /// From the first pass's start to the last pass's end.
    pub total_ms: f32,
}

impl Default for PassTimes {
    fn default() -> Self {
        Self { entries: [("", 0.0); MAX_PASSES], len: 0, total_ms: 0.0 }
    }
}

impl PassTimes {
    /// `(pass name, milliseconds)` pairs in recording order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, f32)> + '_ {
        self.entries[..self.len].iter().copied()
    }

    /// The time of one pass.
    pub fn get(&self, name: &str) -> Option<f32> {
        self.iter().find(|(n, _)| *n == name).map(|(_, ms)| ms)
    }
}

/// Queries of a pool: the start of the first pass, then the end of each.
const QUERIES: u32 = MAX_PASSES as u32 + 1;

/// Timestamp queries for one frame slot.
pub struct GpuTimer {
    pool: vk::QueryPool,
    names: [&'static str; MAX_PASSES],
    len: usize,
    open: bool,
    raw: [u64; MAX_PASSES + 1],
}

impl GpuTimer {
    /// Creates the query pool.
    pub fn new(ctx: &GpuContext) -> Result<Self, RenderError> {
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(QUERIES);
        // SAFETY: valid create info; destroyed in `destroy`.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }?;
        // SAFETY: host reset (Vulkan 1.2 core, enabled) of a pool no command buffer uses yet.
        unsafe { ctx.device.reset_query_pool(pool, 0, QUERIES) };
        Ok(Self { pool, names: [""; MAX_PASSES], len: 0, open: false, raw: [0; MAX_PASSES + 1] })
    }

    /// Reads the previous use's results (its frame has completed) and resets for a new frame.
    pub fn collect(&mut self, ctx: &GpuContext) -> Option<PassTimes> {
        let n = self.len;
        self.len = 0;
        if n == 0 {
            return None;
        }
        let data = &mut self.raw[..n + 1];
        // SAFETY: the queries [0, n] were written by a command buffer that has completed.
        let ok = unsafe { ctx.device.get_query_pool_results(self.pool, 0, data, vk::QueryResultFlags::TYPE_64) };
        // SAFETY: the frame that used the pool has completed; host reset is enabled.
        unsafe { ctx.device.reset_query_pool(self.pool, 0, QUERIES) };
        if let Err(e) = ok {
            tracing::warn!("timestamp results unavailable: {e}");
            return None;
        }
        let to_ms = ctx.timestamp_period_ns as f64 * 1e-6;
        let mut times = PassTimes::default();
        for i in 0..n {
            let ms = data[i + 1].saturating_sub(data[i]) as f64 * to_ms;
            times.entries[i] = (self.names[i], ms as f32);
        }
        times.len = n;
        times.total_ms = (data[n].saturating_sub(data[0]) as f64 * to_ms) as f32;
        Some(times)
    }

    /// Opens a timed pass. Passes beyond [`MAX_PASSES`] are not timed.
    pub fn begin(&mut self, cmd: &Recorder, name: &'static str) {
        debug_assert!(!self.open, "nested GPU timer scopes");
        if self.len >= MAX_PASSES {
            return;
        }
        self.names[self.len] = name;
        self.open = true;
        if self.len == 0 {
            // The query was reset after its last use (`collect`).
            cmd.write_timestamp(vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, 0);
        }
    }

    /// Closes the pass opened by `begin`.
    pub fn end(&mut self, cmd: &Recorder) {
        if !self.open {
            return;
        }
        self.open = false;
        cmd.write_timestamp(vk::PipelineStageFlags2::ALL_COMMANDS, self.pool, (self.len + 1) as u32);
        self.len += 1;
    }

    /// Destroys the pool; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_query_pool(self.pool, None) };
    }
}
