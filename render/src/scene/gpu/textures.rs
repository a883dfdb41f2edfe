//! The bindless set: the material and decal textures' array (set 0, binding 0) and the
//! render targets bound after it, and how a texture is uploaded into its slot.

use super::*;

/// Bindless array size.
pub const MAX_TEXTURES: u32 = 4096;
/// Descriptor bindings after the texture array, one per sampled render target (`BINDING_*`).
pub const TARGET_BINDINGS: u32 = crate::layout::BINDING_ANTIALIASED;
/// Storage-image bindings after those: the decal buffer (`BINDING_DECAL_*`), the shadow debug
/// image, depth peeling's background depth, the HDR target, the anti-aliased colour and the
/// reflection pass's three images; then the environment's (`crate::environment`: its two cubes
/// and the BRDF table sampled, the cubes' levels and the table as storage images); then the
/// decal buffer's emission and the ambient occlusion's two images, storage images again; then
/// the motion vectors (storage) and temporal anti-aliasing's two history images, sampled and as
/// storage images; then SMAA's edges and weights and the reflections' resolved term (storage).
const _: () = assert!(crate::layout::BINDING_DECAL_ALBEDO == TARGET_BINDINGS + 1, "storage bindings follow the sampled targets");
const _: () = assert!(crate::layout::BINDING_ENVIRONMENT == crate::layout::BINDING_REFLECTION_RAYS + 1, "the environment follows them");
/// The sampled bindings among the storage images': the environment's cubes and BRDF table, and
/// temporal anti-aliasing's history.
pub(super) const SAMPLED_LATE: [u32; 5] = [
    crate::layout::BINDING_ENVIRONMENT,
    crate::layout::BINDING_ENVIRONMENT_SOURCE,
    crate::layout::BINDING_BRDF_LUT,
    crate::layout::BINDING_TAA_HISTORY_A,
    crate::layout::BINDING_TAA_HISTORY_B,
];
pub(super) const BINDINGS: usize = 1 + crate::layout::BINDING_REFLECTION_ADDED as usize;

/// The descriptor type of a binding of set 0.
pub(super) fn descriptor_type(binding: u32) -> vk::DescriptorType {
    let storage = binding > TARGET_BINDINGS && !SAMPLED_LATE.contains(&binding);
    if storage { vk::DescriptorType::STORAGE_IMAGE } else { vk::DescriptorType::COMBINED_IMAGE_SAMPLER }
}

/// How many descriptors a binding of set 0 holds.
pub(super) fn descriptor_count(binding: u32) -> u32 {
    match binding {
        0 => MAX_TEXTURES,
        crate::layout::BINDING_ENVIRONMENT_LEVELS => crate::layout::ENVIRONMENT_LEVEL_VIEWS,
        _ => 1,
    }
}

impl GpuScene {
    /// Writes a render target's `view` into its bindless slot, with the clamp sampler. Only for
    /// slots no pending frame samples. Depth is sampled in `DEPTH_READ_ONLY_OPTIMAL`, so it can be
    /// a read-only depth attachment in the same pass.
    pub fn bind_target(&self, ctx: &GpuContext, bind: Bind, view: vk::ImageView) {
        let (binding, layout) = match bind {
            Bind::Color(binding) => (binding, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
            Bind::Depth(binding) => (binding, vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL),
            Bind::Storage(binding) => (binding, vk::ImageLayout::GENERAL),
        };
        let sampler = if bind.is_storage() { vk::Sampler::null() } else { self.clamp_sampler };
        self.write_descriptor_at(ctx, binding, 0, view, sampler, layout);
    }

    /// Writes `view` into element `index` of `binding` in the GENERAL layout (the environment's
    /// images, which its passes write as storage and shading samples), with `sampler` (null for a
    /// storage binding). Only for elements no pending frame uses.
    pub fn bind_general(&self, ctx: &GpuContext, binding: u32, index: u32, view: vk::ImageView, sampler: vk::Sampler) {
        self.write_descriptor_at(ctx, binding, index, view, sampler, vk::ImageLayout::GENERAL);
    }

    pub(super) fn write_descriptor(&self, ctx: &GpuContext, slot: u32, view: vk::ImageView, sampler: vk::Sampler) {
        self.write_descriptor_at(ctx, 0, slot, view, sampler, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
    }

    pub(super) fn write_descriptor_at(
        &self,
        ctx: &GpuContext,
        binding: u32,
        slot: u32,
        view: vk::ImageView,
        sampler: vk::Sampler,
        layout: vk::ImageLayout,
    ) {
        let info = [vk::DescriptorImageInfo { sampler, image_view: view, image_layout: layout }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(binding)
            .dst_array_element(slot)
            .descriptor_type(descriptor_type(binding))
            .image_info(&info);
        // SAFETY: the slot is not used by any pending command buffer (fresh, recycled after
        // completion, or a target rewritten after a wait for idle); the binding is
        // update-after-bind.
        unsafe { ctx.device.update_descriptor_sets(&[write], &[]) };
    }

    /// Creates the image for `data` and prepares its upload: the staging buffer is buried with
    /// this frame, the copy goes into `copies`.
    pub(super) fn prepare_texture(
        &mut self,
        up: &mut Upload,
        copies: &mut CopyList,
        slot: u32,
        data: &TextureData,
    ) -> Result<(), RenderError> {
        let ctx = up.ctx;
        if slot >= MAX_TEXTURES {
            return Err(RenderError::Other(format!("texture slot {slot} exceeds the bindless array ({MAX_TEXTURES})")));
        }
        let rgba8 = matches!(data.format, vk::Format::R8G8B8A8_UNORM | vk::Format::R8G8B8A8_SRGB);
        if !rgba8 && !ctx.capabilities.texture_compression_bc {
            // No device this renderer runs on lacks BC; one that did would need a CPU decoder.
            // The texture samples white instead, and the frame (with the meshes uploaded before
            // it) goes on.
            tracing::warn!(slot, format = ?data.format, "a block-compressed texture on a device without BC texture compression: it samples white");
            if let Some(white) = self.textures.get(TEXTURE_WHITE as usize).and_then(Option::as_ref) {
                self.write_descriptor(ctx, slot, white.view, self.repeat_sampler);
            }
            return Ok(());
        }
        // A block-compressed copy's offset must be a multiple of the block's bytes: each level
        // of such a texture starts 16-byte aligned (RGBA8 levels are multiples of 4 as they are).
        let align = if rgba8 { 4 } else { 16 };
        let mut offset = 0usize;
        for (level, mip) in data.mips.iter().enumerate() {
            let (w, h) = ((data.width >> level).max(1), (data.height >> level).max(1));
            let expected = crate::scene::level_bytes(data.format, w, h)
                .ok_or_else(|| RenderError::Other(format!("textures in {:?} are not sampled by this renderer", data.format)))?;
            if mip.len() as u64 != expected {
                return Err(RenderError::Other(format!("texture mip {level} has {} bytes, expected {expected}", mip.len())));
            }
            offset = offset.next_multiple_of(align) + mip.len();
        }
        let mut staging = Buffer::new(ctx, "texture staging", offset as u64, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
        let src = staging.raw;
        let mapped = staging.mapped();
        let mut offset = 0usize;
        let regions = data.mips.iter().enumerate().map(|(level, mip)| {
            offset = offset.next_multiple_of(align);
            mapped[offset..offset + mip.len()].copy_from_slice(mip);
            let region = vk::BufferImageCopy {
                buffer_offset: offset as u64,
                image_subresource: vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: level as u32,
                    base_array_layer: 0,
                    layer_count: 1,
                },
                image_extent: vk::Extent3D { width: (data.width >> level).max(1), height: (data.height >> level).max(1), depth: 1 },
                ..Default::default()
            };
            offset += mip.len();
            region
        });
        let image = Image::new(
            ctx,
            &ImageDesc {
                name: "texture",
                format: data.format,
                extent: vk::Extent2D { width: data.width, height: data.height },
                mip_levels: data.mips.len() as u32,
                usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                samples: 1,
                kind: MemoryKind::Textures,
            },
        )?;
        copies.image_copy(src, image.raw, image.full_range(), regions);
        up.bytes += offset as u64;
        up.graveyard.bury(up.frame_value, Retired::Buffer(staging));
        self.write_descriptor(ctx, slot, image.view, self.repeat_sampler);
        if self.textures.len() <= slot as usize {
            self.textures.resize_with(slot as usize + 1, || None);
        }
        if let Some(old) = self.textures[slot as usize].replace(image) {
            old.destroy(ctx); // only reachable for built-ins during setup
        }
        Ok(())
    }
}
