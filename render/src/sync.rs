//! Barriers from declarations.
//!
//! A pass states how it will use each image ([`Access`]); [`ImageState`] remembers the last use
//! and [`transition`] emits the one synchronization2 barrier between the two. Passes never place
//! barriers by hand. The state persists across frames: with one queue, the first use in frame N+1
//! is ordered after the last use in frame N by the same rule.

use ash::vk;

/// One way a pass uses an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Nothing yet (contents may be discarded).
    Undefined,
    /// Written as a colour attachment.
    ColorAttachmentWrite,
    /// Depth tested and written.
    DepthAttachmentWrite,
    /// Depth tested, not written (e.g. EQUAL after a prepass).
    DepthAttachmentRead,
    /// Sampled in a fragment shader.
    FragmentSampled,
    /// A depth image sampled in fragment shaders and, in the same pass, bound as a read-only
    /// depth attachment (deferred decals test against it while reconstructing from it).
    DepthSampled,
    /// Sampled in a fragment or compute shader.
    ShaderSampled,
    /// Source of a copy.
    TransferRead,
    /// Destination of a copy.
    TransferWrite,
    /// Handed to the presentation engine.
    Present,
}

impl Access {
    fn stage_access_layout(self) -> (vk::PipelineStageFlags2, vk::AccessFlags2, vk::ImageLayout) {
        use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
        match self {
            Access::Undefined => (S::NONE, A::NONE, L::UNDEFINED),
            Access::ColorAttachmentWrite => {
                (S::COLOR_ATTACHMENT_OUTPUT, A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ, L::COLOR_ATTACHMENT_OPTIMAL)
            }
            Access::DepthAttachmentWrite => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_WRITE | A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_ATTACHMENT_OPTIMAL,
            ),
            Access::DepthAttachmentRead => {
                (S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS, A::DEPTH_STENCIL_ATTACHMENT_READ, L::DEPTH_READ_ONLY_OPTIMAL)
            }
            Access::FragmentSampled => (S::FRAGMENT_SHADER, A::SHADER_SAMPLED_READ, L::SHADER_READ_ONLY_OPTIMAL),
            Access::DepthSampled => (
                S::FRAGMENT_SHADER | S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::SHADER_SAMPLED_READ | A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_READ_ONLY_OPTIMAL,
            ),
            Access::ShaderSampled => (S::FRAGMENT_SHADER | S::COMPUTE_SHADER, A::SHADER_SAMPLED_READ, L::SHADER_READ_ONLY_OPTIMAL),
            Access::TransferRead => (S::COPY | S::BLIT, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL),
            Access::TransferWrite => (S::COPY | S::BLIT | S::CLEAR, A::TRANSFER_WRITE, L::TRANSFER_DST_OPTIMAL),
            Access::Present => (S::NONE, A::NONE, L::PRESENT_SRC_KHR),
        }
    }

    fn writes(self) -> bool {
        matches!(self, Access::ColorAttachmentWrite | Access::DepthAttachmentWrite | Access::TransferWrite | Access::Undefined)
    }

    /// The image layout this access needs.
    pub fn layout(self) -> vk::ImageLayout {
        self.stage_access_layout().2
    }
}

/// An image together with its last declared use.
#[derive(Clone, Copy, Debug)]
pub struct ImageState {
    /// The image.
    pub image: vk::Image,
    /// Its subresources.
    pub range: vk::ImageSubresourceRange,
    /// How it was used last.
    pub last: Access,
}

impl ImageState {
    /// A freshly created image.
    pub fn new(image: vk::Image, range: vk::ImageSubresourceRange) -> Self {
        Self { image, range, last: Access::Undefined }
    }
}

/// Declares that the next commands use `state`'s image as `next`, emitting the barrier that makes
/// that safe. Consecutive reads in the same layout need no barrier. `discard` lets a pass that
/// overwrites the whole image skip preserving its contents.
pub fn transition(device: &ash::Device, cmd: vk::CommandBuffer, state: &mut ImageState, next: Access, discard: bool) {
    let prev = state.last;
    if prev == next && !next.writes() {
        return;
    }
    let (src_stage, src_access, old_layout) = prev.stage_access_layout();
    let (dst_stage, dst_access, new_layout) = next.stage_access_layout();
    let barrier = vk::ImageMemoryBarrier2::default()
        .src_stage_mask(if src_stage.is_empty() { vk::PipelineStageFlags2::ALL_COMMANDS } else { src_stage })
        .src_access_mask(if prev.writes() { src_access } else { vk::AccessFlags2::NONE })
        .dst_stage_mask(if dst_stage.is_empty() { vk::PipelineStageFlags2::ALL_COMMANDS } else { dst_stage })
        .dst_access_mask(dst_access)
        .old_layout(if discard { vk::ImageLayout::UNDEFINED } else { old_layout })
        .new_layout(new_layout)
        .image(state.image)
        .subresource_range(state.range);
    let barriers = [barrier];
    // SAFETY: `cmd` is recording; the barrier describes a live image of this device.
    unsafe { device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&barriers)) };
    state.last = next;
}

/// A global memory barrier between two stage/access pairs (buffer hazards: uploads before
/// shader reads, shader reads before the next upload overwrites).
pub fn memory_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let barriers =
        [vk::MemoryBarrier2::default().src_stage_mask(src.0).src_access_mask(src.1).dst_stage_mask(dst.0).dst_access_mask(dst.1)];
    // SAFETY: `cmd` is recording.
    unsafe { device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&barriers)) };
}
