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
/// G-buffer formats; shaders/gbuffer.frag says why each.
pub const GBUFFER_ALBEDO_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
/// Shading normal × 0.5 + 0.5.
pub const GBUFFER_NORMAL_FORMAT: vk::Format = vk::Format::A2B10G10R10_UNORM_PACK32;
/// Roughness, metallic.
pub const GBUFFER_MATERIAL_FORMAT: vk::Format = vk::Format::R8G8_UNORM;
/// Decal receiver layers (low 8 bits).
pub const GBUFFER_LAYERS_FORMAT: vk::Format = vk::Format::R8_UINT;
/// Visibility buffer: instance slot, triangle index.
pub const VISIBILITY_FORMAT: vk::Format = vk::Format::R32G32_UINT;

/// Bindless slots where render targets are bound for sampling (`SLOT_*` in [`crate::layout`],
/// shared with the shaders).
pub mod slots {
    pub use crate::layout::{
        SLOT_DEPTH as DEPTH, SLOT_GBUFFER_ALBEDO as GBUFFER_ALBEDO, SLOT_GBUFFER_MATERIAL as GBUFFER_MATERIAL,
        SLOT_GBUFFER_NORMAL as GBUFFER_NORMAL, SLOT_HDR as HDR, UINT_SLOT_LAYERS as UINT_LAYERS, UINT_SLOT_VISIBILITY as UINT_VISIBILITY,
    };
}

/// An image and its tracked state.
pub struct Target {
    /// The image.
    pub image: Image,
    /// Its last declared use.
    pub state: ImageState,
}

impl Target {
    fn new(
        ctx: &GpuContext,
        name: &str,
        format: vk::Format,
        extent: vk::Extent2D,
        usage: vk::ImageUsageFlags,
    ) -> Result<Self, RenderError> {
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

/// The deferred pipelines' attribute targets.
pub struct GBuffer {
    /// Albedo and occlusion.
    pub albedo: Target,
    /// Shading normal.
    pub normal: Target,
    /// Roughness and metallic.
    pub material: Target,
    /// Decal receiver layers.
    pub layers: Target,
}

/// The targets of one view. The G-buffer and visibility buffer are created the first time a
/// pipeline needs them and kept (switching pipelines back and forth allocates nothing new).
pub struct Targets {
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Linear radiance.
    pub hdr: Target,
    /// Reverse-Z depth.
    pub depth: Target,
    /// Tone-mapped sRGB output (headless; a window presents the swapchain image instead).
    pub display: Target,
    /// Deferred shading's attributes.
    pub gbuffer: Option<GBuffer>,
    /// The visibility buffer.
    pub visibility: Option<Target>,
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
            gbuffer: None,
            visibility: None,
        })
    }

    /// The G-buffer, created on first use; `bind` is called with (slot, view, is_uint) for each
    /// new target so the bindless set can point at it.
    pub fn gbuffer(&mut self, ctx: &GpuContext, mut bind: impl FnMut(u32, vk::ImageView, bool)) -> Result<&mut GBuffer, RenderError> {
        use vk::ImageUsageFlags as U;
        if self.gbuffer.is_none() {
            let usage = U::COLOR_ATTACHMENT | U::SAMPLED | U::TRANSFER_SRC;
            let g = GBuffer {
                albedo: Target::new(ctx, "gbuffer albedo", GBUFFER_ALBEDO_FORMAT, self.extent, usage)?,
                normal: Target::new(ctx, "gbuffer normal", GBUFFER_NORMAL_FORMAT, self.extent, usage)?,
                material: Target::new(ctx, "gbuffer material", GBUFFER_MATERIAL_FORMAT, self.extent, usage)?,
                layers: Target::new(ctx, "gbuffer layers", GBUFFER_LAYERS_FORMAT, self.extent, usage)?,
            };
            bind(slots::GBUFFER_ALBEDO, g.albedo.image.view, false);
            bind(slots::GBUFFER_NORMAL, g.normal.image.view, false);
            bind(slots::GBUFFER_MATERIAL, g.material.image.view, false);
            bind(slots::UINT_LAYERS, g.layers.image.view, true);
            self.gbuffer = Some(g);
        }
        Ok(self.gbuffer.as_mut().expect("created above"))
    }

    /// The visibility buffer, created on first use (see [`Targets::gbuffer`] for `bind`).
    pub fn visibility(&mut self, ctx: &GpuContext, mut bind: impl FnMut(u32, vk::ImageView, bool)) -> Result<&mut Target, RenderError> {
        use vk::ImageUsageFlags as U;
        if self.visibility.is_none() {
            let t = Target::new(ctx, "visibility", VISIBILITY_FORMAT, self.extent, U::COLOR_ATTACHMENT | U::SAMPLED | U::TRANSFER_SRC)?;
            bind(slots::UINT_VISIBILITY, t.image.view, true);
            self.visibility = Some(t);
        }
        Ok(self.visibility.as_mut().expect("created above"))
    }

    /// Destroys the targets; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.hdr.image.destroy(ctx);
        self.depth.image.destroy(ctx);
        self.display.image.destroy(ctx);
        if let Some(g) = self.gbuffer {
            for t in [g.albedo, g.normal, g.material, g.layers] {
                t.image.destroy(ctx);
            }
        }
        if let Some(v) = self.visibility {
            v.image.destroy(ctx);
        }
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
