//! The egui overlay, drawn over the tone-mapped image by `egui-ash-renderer` (a maintained egui
//! renderer on ash 0.38 and gpu-allocator 0.28, our versions). The UI itself is built by the
//! application; this module only takes egui's output (plain data: clipped meshes and texture
//! changes) and records it into the frame.

use ash::vk;
use egui_ash_renderer::{DynamicRendering, Options, RenderMode, Renderer as EguiRenderer};

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::device::GpuContext;

/// One frame of egui output.
pub struct OverlayFrame {
    /// Tessellated shapes.
    pub primitives: Vec<egui::ClippedPrimitive>,
    /// Texture changes to apply before drawing.
    pub textures_delta: egui::TexturesDelta,
    /// Physical pixels per egui point.
    pub pixels_per_point: f32,
}

/// The egui renderer and the command pool it uploads textures with.
pub struct Overlay {
    renderer: EguiRenderer<egui_ash_renderer::allocator::GpuAllocator>,
    pool: vk::CommandPool,
    textures_to_free: Vec<egui::TextureId>,
}

impl Overlay {
    /// Creates the overlay for targets of `format` (sRGB).
    pub fn new(ctx: &GpuContext, format: vk::Format) -> Result<Self, RenderError> {
        let renderer = EguiRenderer::with_gpu_allocator(
            std::sync::Arc::clone(&ctx.allocator),
            ctx.device.clone(),
            RenderMode::DynamicRendering(DynamicRendering {
                color_attachment_format: format,
                depth_attachment_format: None,
                stencil_attachment_format: None,
            }),
            Options { in_flight_frames: FRAMES_IN_FLIGHT, srgb_framebuffer: true, ..Default::default() },
        )
        .map_err(|e| RenderError::Other(format!("egui renderer: {e}")))?;
        // SAFETY: a pool for the egui renderer's texture uploads; destroyed in `destroy`.
        let pool = unsafe {
            ctx.device.create_command_pool(
                &vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family).flags(vk::CommandPoolCreateFlags::TRANSIENT),
                None,
            )
        }?;
        Ok(Self { renderer, pool, textures_to_free: Vec::new() })
    }

    /// Applies texture changes and empties `frame.textures_delta` (uploads wait for the GPU;
    /// egui changes textures rarely: the font atlas at start-up).
    pub fn prepare(&mut self, ctx: &GpuContext, frame: &mut OverlayFrame) -> Result<(), RenderError> {
        if !self.textures_to_free.is_empty() {
            ctx.wait_idle();
            for id in self.textures_to_free.drain(..) {
                self.renderer.free_texture(id).map_err(|e| RenderError::Other(format!("egui: {e}")))?;
            }
        }
        for (id, deltas) in &frame.textures_delta.set {
            for delta in deltas {
                self.renderer.set_texture(ctx.queue, self.pool, *id, delta).map_err(|e| RenderError::Other(format!("egui: {e}")))?;
            }
        }
        self.textures_to_free.extend(frame.textures_delta.free.iter().copied());
        frame.textures_delta.clear();
        Ok(())
    }

    /// Records the overlay; `cmd` is inside a rendering scope on the target.
    pub fn record(&mut self, cmd: vk::CommandBuffer, extent: vk::Extent2D, frame: &OverlayFrame) -> Result<(), RenderError> {
        self.renderer.cmd_draw(cmd, extent, frame.pixels_per_point, &frame.primitives).map_err(|e| RenderError::Other(format!("egui: {e}")))
    }

    /// Destroys the overlay; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        drop(self.renderer);
        // SAFETY: the GPU is idle.
        unsafe { ctx.device.destroy_command_pool(self.pool, None) };
    }
}
