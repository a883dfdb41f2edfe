//! The vocabulary passes declare with, and what each word means to Vulkan.
//!
//! A declaration says *what* a pass does with a resource (samples it, writes it as a colour
//! attachment, builds it); the pass's [`PassKind`] says *where* (which shader stages). Together
//! they give the synchronization2 stage, access and image layout the graph derives barriers
//! from. No pass names a stage or an access mask.

use ash::vk;

/// What kind of work a pass records; it decides the pipeline stages of shader accesses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassKind {
    /// Draws inside a rendering scope (vertex and fragment shaders).
    Graphics,
    /// Compute dispatches.
    Compute,
    /// Ray-tracing pipeline dispatches (`vkCmdTraceRaysKHR`).
    RayTracing,
    /// Copies.
    Transfer,
    /// Acceleration-structure builds and updates.
    AccelBuild,
}

impl PassKind {
    /// The stages in which this kind's shaders (or fixed functions) access declared resources.
    pub(crate) fn stages(self) -> vk::PipelineStageFlags2 {
        use vk::PipelineStageFlags2 as S;
        match self {
            PassKind::Graphics => S::VERTEX_SHADER | S::FRAGMENT_SHADER,
            PassKind::Compute => S::COMPUTE_SHADER,
            PassKind::RayTracing => S::RAY_TRACING_SHADER_KHR,
            PassKind::Transfer => S::COPY,
            PassKind::AccelBuild => S::ACCELERATION_STRUCTURE_BUILD_KHR,
        }
    }
}

/// How a colour or depth attachment's previous contents are treated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    /// Keep them (the pass adds to what is there).
    Keep,
    /// Clear a colour attachment to this value.
    Clear([f32; 4]),
    /// Clear a depth attachment to this depth.
    ClearDepth(f32),
    /// Throw them away: the pass writes every pixel.
    Discard,
}

impl Load {
    /// Whether the old contents may be thrown away before the pass.
    pub(crate) fn discards(self) -> bool {
        !matches!(self, Load::Keep)
    }
}

/// One way a pass uses an image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ImageUse {
    /// Written as a colour attachment.
    Color(Load),
    /// Depth tested and written.
    DepthWrite(Load),
    /// Depth tested, not written (e.g. EQUAL after a prepass).
    DepthTest,
    /// Depth tested read-only *and* sampled in the same pass (deferred decals reconstruct
    /// positions from the depth they are tested against).
    DepthTestSampled,
    /// Sampled by the pass's shaders (a depth image is sampled in its read-only layout).
    Sampled,
    /// Read as a storage image.
    StorageRead,
    /// Written (and possibly read) as a storage image.
    StorageWrite,
    /// Source of a copy.
    TransferSrc,
    /// Destination of a copy that overwrites the image.
    TransferDst,
    /// Handed to the presentation engine.
    Present,
    /// The single-sampled image a multisampled attachment of the pass resolves into at its end
    /// (declared by [`super::PassBuilder::resolve`], which also declares the read below).
    Resolve,
    /// A multisampled attachment's samples, read by its resolve at the end of the pass.
    ResolveSource,
}

/// Stage, access and layout of one image use, and whether it writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ImageAccess {
    pub stages: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
    pub writes: bool,
    /// The previous contents do not matter (old layout UNDEFINED).
    pub discard: bool,
}

impl ImageUse {
    pub(crate) fn access(self, kind: PassKind, depth: bool) -> ImageAccess {
        use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
        let tests = S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS;
        let (stages, access, layout, writes, discard) = match self {
            ImageUse::Color(load) => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                L::COLOR_ATTACHMENT_OPTIMAL,
                true,
                load.discards(),
            ),
            ImageUse::DepthWrite(load) => (
                tests,
                A::DEPTH_STENCIL_ATTACHMENT_WRITE | A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_ATTACHMENT_OPTIMAL,
                true,
                load.discards(),
            ),
            ImageUse::DepthTest => (tests, A::DEPTH_STENCIL_ATTACHMENT_READ, L::DEPTH_READ_ONLY_OPTIMAL, false, false),
            ImageUse::DepthTestSampled => {
                (tests | kind.stages(), A::DEPTH_STENCIL_ATTACHMENT_READ | A::SHADER_SAMPLED_READ, L::DEPTH_READ_ONLY_OPTIMAL, false, false)
            }
            ImageUse::Sampled => (
                kind.stages(),
                A::SHADER_SAMPLED_READ,
                if depth { L::DEPTH_READ_ONLY_OPTIMAL } else { L::SHADER_READ_ONLY_OPTIMAL },
                false,
                false,
            ),
            ImageUse::StorageRead => (kind.stages(), A::SHADER_STORAGE_READ, L::GENERAL, false, false),
            ImageUse::StorageWrite => (kind.stages(), A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ, L::GENERAL, true, false),
            ImageUse::TransferSrc => (S::COPY | S::BLIT, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL, false, false),
            ImageUse::TransferDst => (S::COPY | S::BLIT | S::CLEAR, A::TRANSFER_WRITE, L::TRANSFER_DST_OPTIMAL, true, true),
            // Resolves read and write in the colour-output stage, depth included (the
            // specification's "multisample resolve operations").
            ImageUse::Resolve => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                if depth { L::DEPTH_ATTACHMENT_OPTIMAL } else { L::COLOR_ATTACHMENT_OPTIMAL },
                true,
                true,
            ),
            ImageUse::ResolveSource => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_READ,
                if depth { L::DEPTH_ATTACHMENT_OPTIMAL } else { L::COLOR_ATTACHMENT_OPTIMAL },
                false,
                false,
            ),
            // Presentation happens after the submit's semaphore signal: nothing to wait for here.
            ImageUse::Present => (S::NONE, A::NONE, L::PRESENT_SRC_KHR, false, false),
        };
        ImageAccess { stages, access, layout, writes, discard }
    }

    /// Whether the use binds the image as an attachment of the pass's rendering scope.
    pub(crate) fn is_attachment(self) -> bool {
        matches!(self, ImageUse::Color(_) | ImageUse::DepthWrite(_) | ImageUse::DepthTest | ImageUse::DepthTestSampled)
    }
}

/// One way a pass uses a buffer or an acceleration structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BufferUse {
    /// Storage-buffer access by the pass's shaders (through device addresses too).
    Storage,
    /// Copy source or destination.
    Transfer,
    /// Vertex and index fetch by the input assembler.
    Vertices,
    /// Indirect draw or dispatch arguments.
    Indirect,
    /// Geometry read by an acceleration-structure build (AABBs, triangles, instances).
    BuildInput,
    /// The images of a texture group (the bindless material and decal textures), sampled.
    SampledImages,
    /// An acceleration structure (or its build scratch): built or updated in an
    /// [`PassKind::AccelBuild`] pass, traced by shaders in any other.
    Accel,
    /// Read by the host once the frame has finished (statistics read back).
    HostRead,
}

impl BufferUse {
    /// Stage and access of a read (`write == false`) or write.
    pub(crate) fn access(self, kind: PassKind, write: bool) -> (vk::PipelineStageFlags2, vk::AccessFlags2) {
        use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
        match (self, write) {
            (BufferUse::Storage, false) => (kind.stages(), A::SHADER_STORAGE_READ),
            (BufferUse::SampledImages, _) => (kind.stages(), A::SHADER_SAMPLED_READ),
            (BufferUse::Storage, true) => (kind.stages(), A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ),
            (BufferUse::Transfer, false) => (S::COPY, A::TRANSFER_READ),
            (BufferUse::Transfer, true) => (S::COPY | S::CLEAR, A::TRANSFER_WRITE),
            (BufferUse::Vertices, _) => (S::INDEX_INPUT | S::VERTEX_ATTRIBUTE_INPUT, A::INDEX_READ | A::VERTEX_ATTRIBUTE_READ),
            (BufferUse::Indirect, _) => (S::DRAW_INDIRECT, A::INDIRECT_COMMAND_READ),
            (BufferUse::BuildInput, _) => (S::ACCELERATION_STRUCTURE_BUILD_KHR, A::SHADER_READ),
            (BufferUse::Accel, false) if kind == PassKind::AccelBuild => {
                (S::ACCELERATION_STRUCTURE_BUILD_KHR, A::ACCELERATION_STRUCTURE_READ_KHR)
            }
            (BufferUse::Accel, true) => {
                (S::ACCELERATION_STRUCTURE_BUILD_KHR, A::ACCELERATION_STRUCTURE_READ_KHR | A::ACCELERATION_STRUCTURE_WRITE_KHR)
            }
            (BufferUse::Accel, false) => (kind.stages(), A::ACCELERATION_STRUCTURE_READ_KHR),
            (BufferUse::HostRead, _) => (S::HOST, A::HOST_READ),
        }
    }
}
