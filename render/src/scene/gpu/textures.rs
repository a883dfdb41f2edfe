//! The bindless set: the material and decal textures' array (set 0, binding 0) and the
//! render targets bound after it, and how a texture is uploaded into its slot.
//!
//! **The texture budget** ([`crate::RendererSettings::texture_budget`]): when the scene's
//! textures (the material and decal textures, not the renderer's own or the environment's)
//! would take more than the budget, the textures being uploaded lose their finest levels, the
//! largest texture's first, one level at a time, until they fit: with no record of how many
//! pixels each texture covers, the finest level of the largest texture is both the most bytes
//! and the level least likely to be seen in full (it is sampled only where a texel is larger
//! than a pixel). Textures already on the GPU keep their levels; a texture is never cut below
//! one level, so a scene whose textures cannot fit even so stays over budget. One warning says
//! so, the first time; [`TextureBudgetReport`] counts what was dropped.

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
pub(super) const BINDINGS: usize = 1 + crate::layout::BINDING_SHADOW_RATIO as usize;

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

/// What the texture budget did since the renderer started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureBudgetReport {
    /// The budget, in bytes (0: none).
    pub budget: u64,
    /// Bytes the scene's textures hold on the GPU now.
    pub resident: u64,
    /// Finest levels dropped to fit the budget.
    pub levels_dropped: u64,
    /// Bytes those levels held.
    pub bytes_dropped: u64,
}

/// The bytes of every level of a texture.
fn texture_bytes(data: &TextureData) -> u64 {
    data.mips.iter().map(|m| m.len() as u64).sum()
}

/// Drops the finest levels of `textures` (the largest texture's first) until they hold at most
/// `room` bytes or every one is down to a single level; returns the levels and bytes dropped.
pub fn fit_textures(textures: &mut [(u32, TextureData)], room: u64) -> (u64, u64) {
    let mut total: u64 = textures.iter().map(|(_, t)| texture_bytes(t)).sum();
    let (mut levels, mut bytes) = (0, 0);
    while total > room {
        let Some((_, largest)) = textures.iter_mut().filter(|(_, t)| t.mips.len() > 1).max_by_key(|(_, t)| t.mips[0].len()) else {
            break;
        };
        let finest = largest.mips.remove(0);
        largest.width = (largest.width / 2).max(1);
        largest.height = (largest.height / 2).max(1);
        total -= finest.len() as u64;
        bytes += finest.len() as u64;
        levels += 1;
    }
    (levels, bytes)
}

impl GpuScene {
    /// Fits the textures about to be uploaded into the budget (see the module docs), warning
    /// once when it drops levels or cannot fit them.
    /// On a device without BC sampling the block-compressed ones are decoded first, so that
    /// the budget weighs what the GPU will hold.
    pub(super) fn apply_texture_budget(&mut self, pending: &mut [(u32, TextureData)], bc: bool) {
        let budget = self.texture_budget.budget;
        if budget == 0 || pending.is_empty() {
            return;
        }
        if !bc {
            for (_, texture) in pending.iter_mut() {
                if let Some(decoded) = crate::scene::bc::decode_to_rgba8(texture) {
                    *texture = decoded;
                }
            }
        }
        // Slots being replaced free what they hold.
        let replaced: u64 = pending.iter().filter_map(|(slot, _)| self.texture_sizes.get(*slot as usize).copied()).sum();
        let resident = self.texture_budget.resident.saturating_sub(replaced);
        let needed = resident + pending.iter().map(|(_, t)| texture_bytes(t)).sum::<u64>();
        if needed <= budget {
            return;
        }
        let (levels, bytes) = fit_textures(pending, budget.saturating_sub(resident));
        self.texture_budget.levels_dropped += levels;
        self.texture_budget.bytes_dropped += bytes;
        if !self.budget_warned {
            self.budget_warned = true;
            let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
            tracing::warn!(
                "the scene's textures need {:.1} MiB, over the texture budget of {:.1} MiB: {levels} finest levels ({:.1} MiB) were dropped{}",
                mib(needed),
                mib(budget),
                mib(bytes),
                if needed - bytes > budget { ", and the textures still do not fit" } else { "" }
            );
        }
    }

    /// Forgets the bytes a released texture slot held.
    pub(super) fn release_texture_bytes(&mut self, slot: u32) {
        if let Some(size) = self.texture_sizes.get_mut(slot as usize) {
            self.texture_budget.resident -= std::mem::take(size);
        }
    }

    /// Sets the texture budget in bytes (0: none), for the uploads that follow.
    pub fn set_texture_budget(&mut self, bytes: u64) {
        self.texture_budget.budget = bytes;
    }

    /// What the texture budget did ([`TextureBudgetReport`]).
    pub fn texture_budget_report(&self) -> TextureBudgetReport {
        self.texture_budget
    }

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
        let table = data.format == vk::Format::R32G32B32A32_SFLOAT;
        if table && slot >= RESERVED_TEXTURES {
            // Fetched texel by texel by the technique that owns it: the materials' sampler filters
            // linearly, which devices need not offer for 32-bit floats.
            return Err(RenderError::Other(format!(
                "texture slot {slot}: RGBA32F is for the renderer's own tables in built-in slots; scene textures are RGBA8 or block-compressed"
            )));
        }
        let compressed = !rgba8 && !table;
        if compressed && !ctx.capabilities.texture_compression_bc {
            // No device this renderer runs on lacks BC: one that did gets the texture decoded
            // to RGBA8 (four times the memory), with one warning.
            let Some(decoded) = crate::scene::bc::decode_to_rgba8(data) else {
                return Err(RenderError::Other(format!("textures in {:?} are not sampled by this renderer", data.format)));
            };
            if !self.decode_warned {
                self.decode_warned = true;
                tracing::warn!(format = ?data.format, "the device cannot sample block-compressed textures: they are decoded to RGBA8 as they upload, at four to eight times the memory");
            }
            return self.prepare_texture(up, copies, slot, &decoded);
        }
        // A copy's offset must be a multiple of the texel block's bytes: each level of a
        // block-compressed or RGBA32F texture starts 16-byte aligned (RGBA8 levels are
        // multiples of 4 as they are).
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
        if slot >= RESERVED_TEXTURES {
            if self.texture_sizes.len() <= slot as usize {
                self.texture_sizes.resize(slot as usize + 1, 0);
            }
            let old = std::mem::replace(&mut self.texture_sizes[slot as usize], texture_bytes(data));
            self.texture_budget.resident = self.texture_budget.resident - old + texture_bytes(data);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(size: u32) -> TextureData {
        let levels = 32 - size.leading_zeros();
        let mips = (0..levels).map(|l| vec![0u8; ((size >> l).max(1) * (size >> l).max(1) * 4) as usize]).collect();
        TextureData { width: size, height: size, format: vk::Format::R8G8B8A8_SRGB, mips }
    }

    #[test]
    fn the_largest_texture_loses_its_finest_levels_first() {
        let mut textures = vec![(10, texture(64)), (11, texture(16))];
        let total: u64 = textures.iter().map(|(_, t)| texture_bytes(t)).sum();
        // Room for all but most of the 64² level 0: one level of the largest goes.
        let (levels, bytes) = fit_textures(&mut textures, total - 64 * 64 * 4 + 100);
        assert_eq!((levels, bytes), (1, 64 * 64 * 4));
        assert_eq!((textures[0].1.width, textures[0].1.mips.len(), textures[1].1.mips.len()), (32, 6, 5));
        // No room at all: every texture ends at one level, and the loop stops.
        let (levels, _) = fit_textures(&mut textures, 0);
        assert_eq!(levels, 5 + 4);
        assert!(textures.iter().all(|(_, t)| t.mips.len() == 1 && t.width == 1));
    }
}
