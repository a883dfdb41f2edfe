//! Statistics the GPU writes into a buffer every frame, brought back without waiting: each frame
//! copies them into the host-visible buffer of its frame slot, and the CPU reads that copy when
//! the slot comes round again (two frames later), once that frame has finished. Clustered decals
//! and tiled light culling report what they measured this way.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::Buffer;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};

/// One host-visible copy of a statistics block per frame slot, and the frame that wrote it.
pub struct StatsReadback {
    slots: Vec<(Buffer, Option<u64>)>,
    bytes: u64,
    res: ResourceId,
}

impl StatsReadback {
    /// Room for `bytes` of statistics per frame slot, tracked by the graph as `name`.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, name: &'static str, bytes: u64) -> Result<Self, RenderError> {
        let mut slots = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            slots.push((Buffer::new(ctx, name, bytes, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?, None));
        }
        Ok(Self { slots, bytes, res: graph.resource(name) })
    }

    /// The statistics the frame that last used this frame's slot copied, with that frame's
    /// value, once it has finished; each copy is handed out once.
    pub fn take(&mut self, f: &Frame) -> Option<(u64, &[u32])> {
        let completed = f.upload.completed;
        let (buffer, written_by) = &mut self.slots[f.slot()];
        let frame = written_by.take().filter(|&v| v <= completed)?;
        Some((frame, bytemuck::cast_slice(&buffer.mapped()[..self.bytes as usize])))
    }

    /// Drops the copies not yet handed out: what they measured is gone (the buffer they came
    /// from was released), and must not come back when the pass runs again.
    pub fn forget(&mut self) {
        for (_, written_by) in &mut self.slots {
            *written_by = None;
        }
    }

    /// Copies the first bytes of `src` (the graph's `source`) for the CPU, as the pass `name`.
    pub fn record(&mut self, f: &mut Frame, name: &'static str, source: ResourceId, src: vk::Buffer) -> Result<(), RenderError> {
        let slot = f.slot();
        let (target, size, res) = (self.slots[slot].0.raw, self.bytes, self.res);
        f.pass(name, PassKind::Transfer).read(source, BufferUse::Transfer).write(res, BufferUse::Transfer).record(|p| {
            let region = vk::BufferCopy { src_offset: 0, dst_offset: 0, size };
            p.cmd.copy_buffer(src, target, &[region]);
        })?;
        f.hand_over_buffer(res, BufferUse::HostRead);
        self.slots[slot].1 = Some(f.upload.frame_value);
        Ok(())
    }

    /// Destroys the buffers; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for (b, _) in self.slots {
            b.destroy(ctx);
        }
    }
}
