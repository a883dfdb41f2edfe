//! Offscreen render targets and their readback.
//!
//! The HDR colour target holds linear radiance (RGBA16F) and is what image tests compare against
//! CPU references; the display target holds the tone-mapped sRGB image that becomes the
//! screenshot. Depth is D32 with reverse-Z (cleared to 0, tested GREATER / EQUAL).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::device::GpuContext;
use crate::memory::{Buffer, Image, ImageDesc};
use crate::sync::{Access, ImageState, transition};

/// HDR colour format.
pub const HDR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Depth format.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// Display (tone-mapped) format.
pub const DISPLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;

/// An image and its tracked state.
pub struct Target {
    /// The image.
    pub image: Image,
    /// Its last declared use.
    pub state: ImageState,
}

impl Target {
    fn new(ctx: &GpuContext, name: &str, format: vk::Format, extent: vk::Extent2D, usage: vk::ImageUsageFlags) -> Result<Self, RenderError> {
        let image = Image::new(ctx, &ImageDesc { name, format, extent, mip_levels: 1, usage })?;
        let state = ImageState::new(image.raw, image.full_range());
        Ok(Self { image, state })
    }

    /// Declares the next use (see [`transition`]).
    pub fn use_as(&mut self, ctx: &GpuContext, cmd: vk::CommandBuffer, access: Access) {
        transition(&ctx.device, cmd, &mut self.state, access, false);
    }

    /// Declares the next use, discarding the current contents.
    pub fn overwrite_as(&mut self, ctx: &GpuContext, cmd: vk::CommandBuffer, access: Access) {
        transition(&ctx.device, cmd, &mut self.state, access, true);
    }
}

/// The targets of one view.
pub struct Targets {
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Linear radiance.
    pub hdr: Target,
    /// Reverse-Z depth.
    pub depth: Target,
    /// Tone-mapped sRGB output (headless; a window presents the swapchain image instead).
    pub display: Target,
}

impl Targets {
    /// Creates targets of `extent`.
    pub fn new(ctx: &GpuContext, extent: vk::Extent2D) -> Result<Self, RenderError> {
        use vk::ImageUsageFlags as U;
        Ok(Self {
            extent,
            hdr: Target::new(ctx, "hdr", HDR_FORMAT, extent, U::COLOR_ATTACHMENT | U::SAMPLED | U::TRANSFER_SRC)?,
            depth: Target::new(ctx, "depth", DEPTH_FORMAT, extent, U::DEPTH_STENCIL_ATTACHMENT | U::SAMPLED | U::TRANSFER_SRC)?,
            display: Target::new(ctx, "display", DISPLAY_FORMAT, extent, U::COLOR_ATTACHMENT | U::TRANSFER_SRC)?,
        })
    }

    /// Destroys the targets; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.hdr.image.destroy(ctx);
        self.depth.image.destroy(ctx);
        self.display.image.destroy(ctx);
    }
}

/// Copies a whole single-mip target into host memory and returns its bytes (tightly packed).
/// Waits for the GPU; for screenshots and tests, never per frame.
pub fn read_back(ctx: &GpuContext, target: &mut Target, bytes_per_pixel: u64) -> Result<Vec<u8>, RenderError> {
    let extent = target.image.extent;
    let size = extent.width as u64 * extent.height as u64 * bytes_per_pixel;
    let mut buffer = Buffer::new(ctx, "readback", size, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?;
    let aspect = target.image.aspect;
    let result = ctx.run_once(|cmd| {
        let previous = target.state.last;
        target.use_as(ctx, cmd, Access::TransferRead);
        let region = vk::BufferImageCopy {
            image_subresource: vk::ImageSubresourceLayers { aspect_mask: aspect, mip_level: 0, base_array_layer: 0, layer_count: 1 },
            image_extent: vk::Extent3D { width: extent.width, height: extent.height, depth: 1 },
            ..Default::default()
        };
        // SAFETY: `cmd` is recording; the image is in TRANSFER_SRC layout and the buffer holds it.
        unsafe { ctx.device.cmd_copy_image_to_buffer(cmd, target.image.raw, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buffer.raw, &[region]) };
        if previous != Access::Undefined {
            target.use_as(ctx, cmd, previous);
        }
    });
    let bytes = result.map(|_| buffer.mapped()[..size as usize].to_vec());
    buffer.destroy(ctx);
    bytes
}

/// Converts an IEEE half float to f32.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h >> 15) & 1) as u32;
    let exp = ((h >> 10) & 0x1f) as u32;
    let mant = (h & 0x3ff) as u32;
    let bits = match (exp, mant) {
        (0, 0) => sign << 31,
        (0, m) => {
            // Subnormal: renormalise.
            let shift = m.leading_zeros() - 21;
            let m = (m << shift) & 0x3ff;
            (sign << 31) | ((127 - 15 + 1 - shift) << 23) | (m << 13)
        }
        (0x1f, m) => (sign << 31) | (0xff << 23) | (m << 13),
        (e, m) => (sign << 31) | ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::f16_to_f32;

    #[test]
    fn half_floats_decode() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x0001), 5.960_464_5e-8);
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
    }
}
