//! Auto-exposure: the display's exposure follows the scene's luminance, as an eye or a camera
//! adapts (issue 26, item 5). None of the seeds treats exposure; the method is the field's
//! standard one (Lagarde and de Rousiers, "Moving Frostbite to PBR", SIGGRAPH 2014, §5.1; the
//! histogram as in Unreal's and Bevy's auto-exposure):
//!
//! 1. **Histogram** (compute, after bloom): every pixel of the HDR target into 128 bins of log2
//!    luminance over 2^−12 to 2^12, per workgroup in shared memory, then into the record.
//! 2. **Average** (one workgroup): the mean log2 luminance of the pixels between the 10th and
//!    90th percentiles (Bevy's default window), black left out, as an EV100 (clamped to the
//!    settings' range, minus the compensation); the adapted EV100 moves towards it by
//!    1 − e^(−rate · dt) (at once on the first frame), and the exposure puts it at 18 % grey
//!    (Unreal's calibration; Frostbite's 1 / (1.2 · 2^EV100) maps it to 10 %, a stop and a
//!    half darker than our scenes are lit for). The pass clears the histogram for the next
//!    frame.
//!
//! The display transform (tone mapping, FXAA) multiplies by the record's exposure, read on the
//! GPU: the CPU never waits for it and nothing is uploaded per frame (the frame's dt travels in
//! the push constants). The record (528 bytes) is made the first time auto-exposure runs and
//! cleared whenever it is switched on, so it starts from the scene as it is.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::Buffer;
use crate::gpu::pipeline::{ScenePush, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::HDR;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::GpuExposure;
use crate::scene::gpu::GpuScene;
use crate::settings::AutoExposure;

/// The auto-exposure passes and their record.
pub struct Exposure {
    histogram: vk::Pipeline,
    average: vk::Pipeline,
    record: Option<Buffer>,
    res: ResourceId,
    /// This frame: whether it runs, and whether its record is cleared first.
    runs: bool,
    reset: bool,
    /// Seconds since the previous frame.
    dt: f32,
}

impl Exposure {
    /// Creates the pipelines; the record is made on the first frame with auto-exposure.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let histogram = create_compute(ctx, layout, "exposure histogram", shaders::EXPOSURE_HISTOGRAM_COMP)?;
        let average = match create_compute(ctx, layout, "exposure average", shaders::EXPOSURE_AVERAGE_COMP) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: never used.
                unsafe { ctx.destroying().destroy_pipeline(histogram, None) };
                return Err(e);
            }
        };
        Ok(Self { histogram, average, record: None, res: graph.resource("exposure"), runs: false, reset: false, dt: 0.0 })
    }

    /// Makes the record when auto-exposure first runs and sets the lighting record's exposure
    /// fields (before the scene's upload); `dt` is the time since the previous frame.
    pub fn prepare(&mut self, f: &mut Frame, scene: &mut GpuScene, settings: &AutoExposure, dt: f32) -> Result<(), RenderError> {
        let runs = settings.runs();
        self.reset = runs && !self.runs;
        self.runs = runs;
        self.dt = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
        if !runs {
            scene.set_exposure(0, [0.0; 4]);
            return Ok(());
        }
        if self.record.is_none() {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC;
            let size = std::mem::size_of::<GpuExposure>() as u64;
            self.record = Some(Buffer::new(f.ctx, "exposure", size, usage, MemoryLocation::GpuOnly)?);
        }
        let address = self.record.as_ref().map_or(0, |b| b.address);
        scene.set_exposure(address, [settings.compensation, settings.min_ev100, settings.max_ev100, settings.rate]);
        Ok(())
    }

    /// What the display transform reads this frame (nothing when the camera's exposure applies).
    pub fn reads(&self) -> Option<(ResourceId, BufferUse)> {
        self.runs.then_some((self.res, BufferUse::Storage))
    }

    /// Records the passes over the finished HDR target: the record's clear when auto-exposure
    /// was just switched on, the histogram, the average and the adaptation.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        let (true, Some(record)) = (self.runs, self.record.as_ref()) else { return Ok(()) };
        let (raw, res) = (record.raw, self.res);
        if self.reset {
            f.pass("exposure_reset", PassKind::Transfer).write(res, BufferUse::Transfer).record(|p| {
                p.cmd.fill_buffer(raw, 0, vk::WHOLE_SIZE, 0);
            })?;
        }
        let extent = f.graph.extent();
        let histogram = self.histogram;
        f.pass("exposure_histogram", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .sample(&HDR)
            .write(res, BufferUse::Storage)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, histogram, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(16), extent.height.div_ceil(16), 1);
            })?;
        let (average, dt) = (self.average, self.dt);
        f.pass("exposure_average", PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(res, BufferUse::Storage).record(
            |p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, average, &ScenePush { texture_index: dt.to_bits(), ..p.push });
                p.cmd.dispatch(1, 1, 1);
            },
        )
    }

    /// The record's exposure, EV100 and the luminance it adapts to, and how many frames adapted
    /// (waits for the GPU; `None` before auto-exposure first ran). For tests and statistics.
    pub fn read_back(&self, ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Option<GpuExposure>, RenderError> {
        let Some(record) = self.record.as_ref() else { return Ok(None) };
        let bytes = graph.read_back_buffer(ctx, self.res, record.raw, std::mem::size_of::<GpuExposure>() as u64)?;
        Ok(Some(bytemuck::pod_read_unaligned(&bytes)))
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(mut self, ctx: &GpuContext) {
        for p in [self.histogram, self.average] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some(b) = self.record.take() {
            b.destroy(ctx);
        }
    }
}
