//! A frame graph in miniature: passes declare what they read and write, and the graph derives
//! every barrier and layout transition, begins and ends rendering, and times each pass.
//!
//! In the spirit of kajiya's render graph and Frostbite's FrameGraph, sized for this project:
//!
//! - **Resources** are images ([`ImageId`]) and buffers or acceleration structures
//!   ([`ResourceId`]). Render targets are described once by a [`TargetDesc`] and created by the
//!   graph on first use, kept across frames (a steady-state frame allocates nothing) and
//!   recreated after [`FrameGraph::resize`]. Other images (swapchain images) are imported, and
//!   buffers are registered as logical resources: "the scene tables", "the decal BLAS".
//! - **Passes** are declared with a name, a [`PassKind`] and their uses ([`ImageUse`],
//!   [`BufferUse`]) through [`Frame::pass`], then recorded with [`PassBuilder::record`].
//! - **Barriers** come from the declarations only. Each resource remembers its last write and
//!   the stages that have read it since; a read waits for the last write (once per stage), a
//!   write waits for the last write and every read since (write-after-read), and an image whose
//!   layout must change is transitioned. One `vkCmdPipelineBarrier2` per pass carries them all.
//!   State persists across frames: with one queue, frame N+1's first use waits for frame N's
//!   last by the same rule. (An imported swapchain image instead waits for its acquire
//!   semaphore, at [`ACQUIRE_WAIT_STAGE`].)
//!
//! **Why immediate, not compiled.** Kajiya and Frostbite collect the whole frame first, then cull
//! unused passes, alias transient memory and reorder. Our frames are short fixed sequences (one
//! function per pipeline) in which every declared pass contributes, so the graph derives each
//! pass's barriers as it is declared and records it at once: the same barriers with no frame
//! representation to build, and no closures to box (nothing allocates per frame). The
//! declarations are the interface, so a compiled graph could replace this one without touching
//! a pass.
//!
//! Nothing outside this module calls `vkCmdPipelineBarrier2`. Two barriers here are not derived
//! from declarations: an image readback's host-read barrier (buffers read back every frame
//! declare theirs, [`BufferUse::HostRead`]), and the one between the steps of a chain of
//! dispatches inside one pass ([`PassContext::compute_to_compute`]: the levels of the depth
//! pyramids and of bloom, which a pass each would time, bind and fence one by one). The frame's
//! semaphores are stated by the renderer's submit.
//!
//! Known limits: a track remembers which stages have seen the last write, not which kinds of
//! access, so a second read in the same stage by another kind of access (a storage read after a
//! sampled one) would get no barrier; no pass does that today. A frame that fails part-way is not
//! submitted, but the state it recorded stays: such an error is fatal to the renderer.

pub mod access;
pub mod pass;
pub mod pyramid;
pub mod readback;
pub mod targets;

use ash::vk;

use crate::RenderError;
use crate::gpu::commands::Recorder;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Image, ImageDesc, MemoryKind};
use crate::gpu::pipeline::ScenePush;
use crate::gpu::timestamps::GpuTimer;
use crate::gpu::upload::Upload;

use access::ImageAccess;
pub use access::{BufferUse, ImageUse, Load, PassKind};
pub use pass::PassContext;
pub use targets::{Bind, TargetDesc};

/// The stage at which a frame's submit waits for an imported image (the swapchain acquire): the
/// first pass that writes one is a colour-attachment pass. Work before it (uploads, acceleration
/// structures) does not wait for the acquire.
pub const ACQUIRE_WAIT_STAGE: vk::PipelineStageFlags2 = vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT;

/// An image the graph tracks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageId(u16);

/// A buffer or acceleration structure the graph tracks (a logical resource: it may stand for a
/// group of buffers that are always used together, such as the scene's record tables).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ResourceId(u16);

/// What happened to a resource lately: the last write and the readers since.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Track {
    /// Stages and accesses of the last write (a layout transition counts as one, with no
    /// access).
    write: Option<(vk::PipelineStageFlags2, vk::AccessFlags2)>,
    /// Stages the last write has been made visible to.
    visible: vk::PipelineStageFlags2,
    /// Stages that read since the last write.
    readers: vk::PipelineStageFlags2,
}

impl Track {
    /// The dependency a use needs (source stage and access), updating the track; `None` when the
    /// use needs no barrier.
    fn depend(&mut self, stages: vk::PipelineStageFlags2, access: vk::AccessFlags2, writes: bool, transition: bool) -> Option<Dep> {
        let write = self.write;
        let dep = if writes || transition {
            // Wait for the last write and every read since (write-after-read, -after-write).
            let (ws, wa) = write.unwrap_or_default();
            Some(Dep { src_stages: ws | self.readers, src_access: wa, dst_stages: stages, dst_access: access })
        } else {
            // A read waits for the last write, once per stage.
            write.filter(|_| !self.visible.contains(stages)).map(|(ws, wa)| Dep {
                src_stages: ws,
                src_access: wa,
                dst_stages: stages,
                dst_access: access,
            })
        };
        if writes {
            *self = Track {
                write: Some((stages, access)),
                visible: vk::PipelineStageFlags2::empty(),
                readers: vk::PipelineStageFlags2::empty(),
            };
        } else if transition {
            // The transition happens before `stages`; later readers chain on it.
            *self = Track { write: Some((stages, vk::AccessFlags2::NONE)), visible: stages, readers: stages };
        } else {
            self.visible |= stages;
            self.readers |= stages;
        }
        dep.filter(|d| !d.src_stages.is_empty() || transition)
    }
}

#[derive(Clone, Copy, Debug)]
struct Dep {
    src_stages: vk::PipelineStageFlags2,
    src_access: vk::AccessFlags2,
    dst_stages: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
}

/// The state of one tracked image: its layout and its [`Track`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageState {
    layout: vk::ImageLayout,
    track: Track,
}

impl Default for ImageState {
    fn default() -> Self {
        Self { layout: vk::ImageLayout::UNDEFINED, track: Track::default() }
    }
}

struct ImageEntry {
    /// Set for targets the graph creates; `None` for imported images.
    desc: Option<&'static TargetDesc>,
    /// A target of its own size, not the view's (kept across resizes).
    fixed: Option<vk::Extent2D>,
    owned: Option<Image>,
    raw: vk::Image,
    view: vk::ImageView,
    extent: vk::Extent2D,
    range: vk::ImageSubresourceRange,
    depth: bool,
    state: ImageState,
}

struct ResourceEntry {
    track: Track,
    /// New images the next pass that writes this resource fills by copies (see
    /// [`PassBuilder::upload_images`]): they are moved from UNDEFINED to TRANSFER_DST first.
    fresh_images: Vec<(vk::Image, vk::ImageSubresourceRange)>,
    /// Images filled by a copy and not yet made sampleable: the next pass that reads this
    /// resource transitions them.
    pending_images: Vec<(vk::Image, vk::ImageSubresourceRange)>,
    /// New images the next pass that writes this resource writes as storage (see
    /// [`PassBuilder::storage_images`]): moved from UNDEFINED to GENERAL, where they stay.
    general_images: Vec<(vk::Image, vk::ImageSubresourceRange)>,
}

/// One declaration of a pass.
#[derive(Clone, Copy, Debug)]
enum Decl {
    Image(ImageRef, ImageUse),
    Resource(ResourceId, BufferUse, bool),
}

/// An image named in a declaration: a tracked image, or a target created on first use.
#[derive(Clone, Copy, Debug)]
pub enum ImageRef {
    /// An image already known to the graph.
    Id(ImageId),
    /// A render target, created from its description the first time it is named.
    Target(&'static TargetDesc),
}

impl From<ImageId> for ImageRef {
    fn from(id: ImageId) -> Self {
        ImageRef::Id(id)
    }
}

impl From<&'static TargetDesc> for ImageRef {
    fn from(desc: &'static TargetDesc) -> Self {
        ImageRef::Target(desc)
    }
}

/// The graph: tracked resources, the targets it owns, and scratch space reused every pass.
pub struct FrameGraph {
    images: Vec<ImageEntry>,
    resources: Vec<ResourceEntry>,
    extent: vk::Extent2D,
    /// Targets created since [`FrameGraph::take_new_bindings`] was last called, to be bound in
    /// the bindless set.
    new_bindings: Vec<(Bind, vk::ImageView)>,
    decls: Vec<Decl>,
    image_barriers: Vec<vk::ImageMemoryBarrier2<'static>>,
    colors: Vec<vk::RenderingAttachmentInfo<'static>>,
    /// Images dropped by a resize, destroyed once the GPU is idle.
    retired: Vec<Image>,
    /// Samples a pixel of the multisampled targets ([`TargetDesc::multisampled`]).
    samples: u32,
}

impl FrameGraph {
    /// An empty graph whose targets are `extent` pixels.
    pub fn new(extent: vk::Extent2D) -> Self {
        Self {
            images: Vec::new(),
            resources: Vec::new(),
            extent,
            new_bindings: Vec::new(),
            decls: Vec::with_capacity(32),
            image_barriers: Vec::with_capacity(32),
            colors: Vec::with_capacity(8),
            retired: Vec::new(),
            samples: 1,
        }
    }

    /// The size of the render targets.
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    /// Registers a logical buffer or acceleration-structure resource.
    pub fn resource(&mut self, name: &'static str) -> ResourceId {
        self.resources.push(ResourceEntry {
            track: Track::default(),
            fresh_images: Vec::new(),
            pending_images: Vec::new(),
            general_images: Vec::new(),
        });
        tracing::debug!(resource = name, id = self.resources.len() - 1, "frame graph resource");
        ResourceId((self.resources.len() - 1) as u16)
    }

    /// Registers an image the graph does not own (a swapchain image); its view, extent and state
    /// are set each frame with [`FrameGraph::import`].
    pub fn external_image(&mut self, name: &'static str) -> ImageId {
        tracing::debug!(image = name, id = self.images.len(), "frame graph external image");
        self.images.push(ImageEntry {
            desc: None,
            fixed: None,
            owned: None,
            raw: vk::Image::null(),
            view: vk::ImageView::null(),
            extent: vk::Extent2D::default(),
            range: color_range(),
            depth: false,
            state: ImageState::default(),
        });
        ImageId((self.images.len() - 1) as u16)
    }

    /// Points an external image at `raw`/`view` for this frame, in the layout of `state`. The
    /// image comes from a semaphore wait (a swapchain acquire) at [`ACQUIRE_WAIT_STAGE`], so its
    /// first use this frame is ordered after that stage: the barrier chains on the wait.
    pub fn import(&mut self, id: ImageId, raw: vk::Image, view: vk::ImageView, extent: vk::Extent2D, state: ImageState) {
        let e = &mut self.images[id.0 as usize];
        let acquired = Track { write: Some((ACQUIRE_WAIT_STAGE, vk::AccessFlags2::NONE)), ..Track::default() };
        (e.raw, e.view, e.extent, e.state) = (raw, view, extent, ImageState { layout: state.layout, track: acquired });
    }

    /// The Vulkan image behind `id` (for passes that copy between targets).
    pub fn raw(&self, id: ImageId) -> vk::Image {
        self.images[id.0 as usize].raw
    }

    /// The state an external image was left in (to hand to the next [`FrameGraph::import`]).
    pub fn state(&self, id: ImageId) -> ImageState {
        self.images[id.0 as usize].state
    }

    /// The image of a target, creating it on first use.
    pub fn target(&mut self, ctx: &GpuContext, desc: &'static TargetDesc) -> Result<ImageId, RenderError> {
        if let Some(i) = self.images.iter().position(|e| e.desc.is_some_and(|d| std::ptr::eq(d, desc))) {
            if self.images[i].owned.is_some() {
                return Ok(ImageId(i as u16));
            }
            self.create_target(ctx, i)?;
            return Ok(ImageId(i as u16));
        }
        self.add_target(ctx, desc, None)
    }

    /// The image of a target of its own size (a shadow-map atlas), created at `extent` on first
    /// use and kept, whatever later calls ask, until the graph is destroyed: resizes of the view
    /// leave it alone.
    pub fn fixed_target(&mut self, ctx: &GpuContext, desc: &'static TargetDesc, extent: vk::Extent2D) -> Result<ImageId, RenderError> {
        if let Some(i) = self.images.iter().position(|e| e.desc.is_some_and(|d| std::ptr::eq(d, desc))) {
            return Ok(ImageId(i as u16));
        }
        self.add_target(ctx, desc, Some(extent))
    }

    /// Registers and creates a target, of the view's size or of `fixed`.
    fn add_target(&mut self, ctx: &GpuContext, desc: &'static TargetDesc, fixed: Option<vk::Extent2D>) -> Result<ImageId, RenderError> {
        self.images.push(ImageEntry {
            desc: Some(desc),
            fixed,
            owned: None,
            raw: vk::Image::null(),
            view: vk::ImageView::null(),
            extent: fixed.unwrap_or(self.extent),
            range: color_range(),
            depth: false,
            state: ImageState::default(),
        });
        let i = self.images.len() - 1;
        self.create_target(ctx, i)?;
        Ok(ImageId(i as u16))
    }

    fn create_target(&mut self, ctx: &GpuContext, i: usize) -> Result<(), RenderError> {
        let desc = self.images[i].desc.expect("targets have a description");
        let extent = self.images[i].fixed.unwrap_or(self.extent);
        let samples = if desc.multisampled { self.samples } else { 1 };
        let image = Image::new(
            ctx,
            &ImageDesc {
                name: desc.name,
                format: desc.format,
                extent,
                mip_levels: 1,
                usage: desc.usage,
                samples,
                kind: MemoryKind::Targets,
            },
        )?;
        let e = &mut self.images[i];
        (e.raw, e.view, e.extent, e.range) = (image.raw, image.view, image.extent, image.full_range());
        e.depth = image.aspect.contains(vk::ImageAspectFlags::DEPTH);
        e.state = ImageState::default();
        if let Some(binding) = desc.storage {
            self.new_bindings.push((Bind::Storage(binding), image.view));
        }
        if let Some(bind) = desc.bind {
            self.new_bindings.push((bind, image.view));
        }
        e.owned = Some(image);
        Ok(())
    }

    /// A target's image if it has been created (for readback).
    fn existing_target(&self, desc: &'static TargetDesc) -> Option<ImageId> {
        self.images.iter().position(|e| e.owned.is_some() && e.desc.is_some_and(|d| std::ptr::eq(d, desc))).map(|i| ImageId(i as u16))
    }

    /// Targets created since the last call and the bindless slots they belong in.
    pub fn take_new_bindings(&mut self) -> impl Iterator<Item = (Bind, vk::ImageView)> + '_ {
        self.new_bindings.drain(..)
    }

    /// Drops every target; they are created again at `extent` when next used. The GPU must be
    /// idle (call [`FrameGraph::destroy_retired`] after the wait).
    pub fn resize(&mut self, extent: vk::Extent2D) {
        self.extent = extent;
        for e in self.images.iter_mut().filter(|e| e.fixed.is_none()) {
            if let Some(image) = e.owned.take() {
                self.retired.push(image);
            }
        }
    }

    /// Sets the samples a pixel of the multisampled targets: those made at another count are
    /// dropped, to be created again when next used (the GPU must be idle, as for a resize).
    pub fn set_samples(&mut self, samples: u32) {
        if samples != self.samples {
            self.samples = samples;
            self.drop_multisampled();
        }
    }

    /// Drops the multisampled targets (MSAA switched off: their memory returns); the GPU must
    /// be idle.
    pub fn drop_multisampled(&mut self) {
        for e in self.images.iter_mut().filter(|e| e.desc.is_some_and(|d| d.multisampled)) {
            if let Some(image) = e.owned.take() {
                self.retired.push(image);
            }
        }
    }

    /// Destroys the targets a resize dropped; the GPU must no longer use them.
    pub fn destroy_retired(&mut self, ctx: &GpuContext) {
        for image in self.retired.drain(..) {
            image.destroy(ctx);
        }
    }

    /// Copies a whole single-mip target into host memory and returns its bytes (tightly
    /// packed). Waits for the GPU; for screenshots and tests, never per frame.
    pub fn read_back(&mut self, ctx: &GpuContext, desc: &'static TargetDesc, bytes_per_pixel: u64) -> Result<Vec<u8>, RenderError> {
        let id =
            self.existing_target(desc).ok_or_else(|| RenderError::Other(format!("nothing has been rendered into `{}` yet", desc.name)))?;
        let e = &self.images[id.0 as usize];
        let (raw, extent, aspect) = (e.raw, e.extent, e.range.aspect_mask);
        let size = extent.width as u64 * extent.height as u64 * bytes_per_pixel;
        let mut buffer = Buffer::new(ctx, "readback", size, vk::BufferUsageFlags::TRANSFER_DST, gpu_allocator::MemoryLocation::GpuToCpu)?;
        let result = ctx.run_once(|rec, cmd| {
            self.decls.clear();
            self.decls.push(Decl::Image(ImageRef::Id(id), ImageUse::TransferSrc));
            self.emit_barriers(rec, PassKind::Transfer);
            let region = vk::BufferImageCopy {
                image_subresource: vk::ImageSubresourceLayers { aspect_mask: aspect, mip_level: 0, base_array_layer: 0, layer_count: 1 },
                image_extent: vk::Extent3D { width: extent.width, height: extent.height, depth: 1 },
                ..Default::default()
            };
            // SAFETY: `cmd` is recording; the barrier above put the image in TRANSFER_SRC layout
            // and the buffer holds the whole image.
            unsafe { ctx.device.cmd_copy_image_to_buffer(cmd, raw, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buffer.raw, &[region]) };
            copy_visible_to_host(rec);
        });
        let bytes = result.map(|_| buffer.mapped()[..size as usize].to_vec());
        buffer.destroy(ctx);
        bytes
    }

    /// Copies every layer of level `level` of `image` (a storage image of `resource`, kept in
    /// GENERAL: the environment's cubes) into host memory, layer after layer, `bytes_per_texel`
    /// a texel. Waits for the GPU; for tests and tools.
    pub fn read_back_general_image(
        &mut self,
        ctx: &GpuContext,
        resource: ResourceId,
        image: &Image,
        level: u32,
        bytes_per_texel: u64,
    ) -> Result<Vec<u8>, RenderError> {
        let (width, height) = ((image.extent.width >> level).max(1), (image.extent.height >> level).max(1));
        let size = width as u64 * height as u64 * image.layers as u64 * bytes_per_texel;
        let mut buffer = Buffer::new(ctx, "readback", size, vk::BufferUsageFlags::TRANSFER_DST, gpu_allocator::MemoryLocation::GpuToCpu)?;
        let result = ctx.run_once(|rec, cmd| {
            self.decls.clear();
            self.decls.push(Decl::Resource(resource, BufferUse::Transfer, false));
            self.emit_barriers(rec, PassKind::Transfer);
            let region = vk::BufferImageCopy {
                image_subresource: vk::ImageSubresourceLayers {
                    aspect_mask: image.aspect,
                    mip_level: level,
                    base_array_layer: 0,
                    layer_count: image.layers,
                },
                image_extent: vk::Extent3D { width, height, depth: 1 },
                ..Default::default()
            };
            // SAFETY: `cmd` is recording; the image stays in GENERAL, the barrier above made its
            // last write visible to copies, and the buffer holds the whole level.
            unsafe { ctx.device.cmd_copy_image_to_buffer(cmd, image.raw, vk::ImageLayout::GENERAL, buffer.raw, &[region]) };
            copy_visible_to_host(rec);
        });
        let bytes = result.map(|_| buffer.mapped()[..size as usize].to_vec());
        buffer.destroy(ctx);
        bytes
    }

    /// Copies the first `size` bytes of `src`, tracked as `resource`, to the host (waits for the
    /// GPU). For tests and tools: it submits and waits on its own.
    pub fn read_back_buffer(&mut self, ctx: &GpuContext, resource: ResourceId, src: vk::Buffer, size: u64) -> Result<Vec<u8>, RenderError> {
        self.read_back_buffer_range(ctx, resource, src, 0, size)
    }

    /// Copies `size` bytes of `src` from `offset`, tracked as `resource`, to the host (waits for
    /// the GPU): [`FrameGraph::read_back_buffer`] for a part of a buffer.
    pub fn read_back_buffer_range(
        &mut self,
        ctx: &GpuContext,
        resource: ResourceId,
        src: vk::Buffer,
        offset: u64,
        size: u64,
    ) -> Result<Vec<u8>, RenderError> {
        let mut buffer =
            Buffer::new(ctx, "readback", size.max(4), vk::BufferUsageFlags::TRANSFER_DST, gpu_allocator::MemoryLocation::GpuToCpu)?;
        let result = ctx.run_once(|rec, _| {
            self.decls.clear();
            self.decls.push(Decl::Resource(resource, BufferUse::Transfer, false));
            self.emit_barriers(rec, PassKind::Transfer);
            // The barrier above made the buffer's last write visible to copies, and both buffers
            // hold `size` bytes (the source from `offset`).
            rec.copy_buffer(src, buffer.raw, &[vk::BufferCopy { src_offset: offset, dst_offset: 0, size }]);
            copy_visible_to_host(rec);
        });
        let bytes = result.map(|_| buffer.mapped()[..size as usize].to_vec());
        buffer.destroy(ctx);
        bytes
    }

    /// The image a declaration names (creating a target on first use).
    fn image_id(&mut self, ctx: &GpuContext, image: ImageRef) -> Result<ImageId, RenderError> {
        match image {
            ImageRef::Id(id) => Ok(id),
            ImageRef::Target(desc) => self.target(ctx, desc),
        }
    }

    /// Derives and records the barriers the current declarations need (one call).
    fn emit_barriers(&mut self, cmd: &Recorder, kind: PassKind) {
        let mut memory: Option<Dep> = None;
        let mut merge = |dep: Dep| {
            memory = Some(match memory {
                None => dep,
                Some(m) => Dep {
                    src_stages: m.src_stages | dep.src_stages,
                    src_access: m.src_access | dep.src_access,
                    dst_stages: m.dst_stages | dep.dst_stages,
                    dst_access: m.dst_access | dep.dst_access,
                },
            })
        };
        self.image_barriers.clear();
        for decl in &self.decls {
            match *decl {
                Decl::Image(ImageRef::Id(id), use_) => {
                    let e = &mut self.images[id.0 as usize];
                    let a: ImageAccess = use_.access(kind, e.depth);
                    if use_ == ImageUse::ResolveSource {
                        // Read by the resolve at the end of the pass that writes it: ordered
                        // within the pass, so no barrier; the next write waits for this read.
                        e.state.track.readers |= a.stages;
                        e.state.track.visible |= a.stages;
                        continue;
                    }
                    let transition = e.state.layout != a.layout || a.discard;
                    if let Some(dep) = e.state.track.depend(a.stages, a.access, a.writes, transition) {
                        let old = if a.discard { vk::ImageLayout::UNDEFINED } else { e.state.layout };
                        self.image_barriers.push(image_barrier(dep, old, a.layout, e.raw, e.range));
                    }
                    e.state.layout = a.layout;
                }
                Decl::Image(ImageRef::Target(_), _) => unreachable!("targets are resolved when declared"),
                Decl::Resource(id, use_, write) => {
                    let e = &mut self.resources[id.0 as usize];
                    let (stages, access) = use_.access(kind, write);
                    // Images uploaded into this resource become sampleable for their first sampler;
                    // the transition then counts as the resource's last write, so later readers in
                    // other stages chain on it.
                    if use_ == BufferUse::SampledImages && !e.pending_images.is_empty() {
                        let (ws, wa) = e.track.write.unwrap_or_default();
                        let dep = Dep { src_stages: ws, src_access: wa, dst_stages: stages, dst_access: access };
                        for (raw, range) in e.pending_images.drain(..) {
                            let layout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
                            self.image_barriers.push(image_barrier(dep, vk::ImageLayout::TRANSFER_DST_OPTIMAL, layout, raw, range));
                        }
                        e.track = Track { write: Some((stages, vk::AccessFlags2::NONE)), visible: stages, readers: stages };
                    }
                    if let Some(dep) = e.track.depend(stages, access, write, false) {
                        merge(dep);
                    }
                    // New images this pass fills start in TRANSFER_DST (their old contents are
                    // undefined); the pass's first reader makes them sampleable (above).
                    if write {
                        let dep = Dep {
                            src_stages: vk::PipelineStageFlags2::NONE,
                            src_access: vk::AccessFlags2::NONE,
                            dst_stages: stages,
                            dst_access: access,
                        };
                        for (raw, range) in e.fresh_images.drain(..) {
                            let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
                            self.image_barriers.push(image_barrier(dep, vk::ImageLayout::UNDEFINED, layout, raw, range));
                            e.pending_images.push((raw, range));
                        }
                        for (raw, range) in e.general_images.drain(..) {
                            self.image_barriers.push(image_barrier(dep, vk::ImageLayout::UNDEFINED, vk::ImageLayout::GENERAL, raw, range));
                        }
                    }
                }
            }
        }
        let memory_barriers: &[vk::MemoryBarrier2] = &match memory {
            Some(d) => [vk::MemoryBarrier2::default()
                .src_stage_mask(d.src_stages)
                .src_access_mask(d.src_access)
                .dst_stage_mask(d.dst_stages)
                .dst_access_mask(d.dst_access)],
            None => [vk::MemoryBarrier2::default()],
        }[..memory.is_some() as usize];
        if self.image_barriers.is_empty() && memory_barriers.is_empty() {
            return;
        }
        // Every barrier names a live image of this device with a range inside it.
        cmd.barrier(memory_barriers, &self.image_barriers);
    }
}

/// Whether `format` holds integers (resolved by taking a sample: they cannot be averaged).
fn is_integer(format: vk::Format) -> bool {
    use vk::Format as F;
    matches!(format, F::R32_UINT | F::R32G32_UINT | F::R32G32B32A32_UINT | F::R16_UINT | F::R8_UINT | F::R32_SINT)
}

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn image_barrier(
    dep: Dep,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    image: vk::Image,
    range: vk::ImageSubresourceRange,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(if dep.src_stages.is_empty() { vk::PipelineStageFlags2::NONE } else { dep.src_stages })
        .src_access_mask(dep.src_access)
        .dst_stage_mask(if dep.dst_stages.is_empty() { vk::PipelineStageFlags2::ALL_COMMANDS } else { dep.dst_stages })
        .dst_access_mask(dep.dst_access)
        .old_layout(old)
        .new_layout(new)
        .image(image)
        .subresource_range(range)
}

/// One frame being recorded: the command buffer, the graph, the frame's timer and the state
/// every pass shares (pipeline layout, bindless set, push constants).
pub struct Frame<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    /// The frame's commands (`crate::gpu::commands`).
    pub cmd: &'a Recorder<'a>,
    /// The graph.
    pub graph: &'a mut FrameGraph,
    /// This frame's GPU timer.
    pub timer: &'a mut GpuTimer,
    /// The layout shared by all pipelines.
    pub layout: vk::PipelineLayout,
    /// The bindless set.
    pub bindless: vk::DescriptorSet,
    /// Push constants for scene passes.
    pub push: ScenePush,
    /// Staging, graveyard and timeline values for the frame's uploads and allocations.
    pub upload: Upload<'a>,
}

impl<'a> Frame<'a> {
    /// An index in `0..FRAMES_IN_FLIGHT`, the same for every frame that uses this frame's slot:
    /// for resources kept per slot, written while the slot's previous frame is known finished.
    pub fn slot(&self) -> usize {
        (self.upload.frame_value % crate::gpu::FRAMES_IN_FLIGHT as u64) as usize
    }

    /// Declares a use of `image` outside any pass (handing a swapchain image to presentation):
    /// records only the barrier it needs.
    pub fn hand_over(&mut self, image: ImageId, use_: ImageUse) {
        self.graph.decls.clear();
        self.graph.decls.push(Decl::Image(ImageRef::Id(image), use_));
        self.graph.emit_barriers(self.cmd, PassKind::Transfer);
    }

    /// Declares a use of `resource` outside any pass (handing a readback buffer to the host):
    /// records only the barrier it needs.
    pub fn hand_over_buffer(&mut self, resource: ResourceId, use_: BufferUse) {
        self.graph.decls.clear();
        self.graph.decls.push(Decl::Resource(resource, use_, false));
        self.graph.emit_barriers(self.cmd, PassKind::Transfer);
    }

    /// Starts declaring a pass.
    pub fn pass(&mut self, name: &'static str, kind: PassKind) -> PassBuilder<'_, 'a> {
        self.graph.decls.clear();
        PassBuilder { frame: self, name, kind, error: None, area: None }
    }
}

/// A pass being declared; [`PassBuilder::record`] records it.
#[must_use = "a declared pass does nothing until it is recorded"]
pub struct PassBuilder<'f, 'a> {
    frame: &'f mut Frame<'a>,
    name: &'static str,
    kind: PassKind,
    error: Option<RenderError>,
    area: Option<vk::Extent2D>,
}

impl PassBuilder<'_, '_> {
    /// Declares a use of an image (a tracked image or a target).
    pub fn image(mut self, image: impl Into<ImageRef>, use_: ImageUse) -> Self {
        match self.frame.graph.image_id(self.frame.ctx, image.into()) {
            Ok(id) => self.frame.graph.decls.push(Decl::Image(ImageRef::Id(id), use_)),
            Err(e) => self.error = self.error.or(Some(e)),
        }
        self
    }

    /// Declares a colour attachment (in declaration order: location 0, 1, …).
    pub fn color(self, image: impl Into<ImageRef>, load: Load) -> Self {
        self.image(image, ImageUse::Color(load))
    }

    /// Declares that the pass's shaders sample `image`.
    pub fn sample(self, image: impl Into<ImageRef>) -> Self {
        self.image(image, ImageUse::Sampled)
    }

    /// Declares that the pass reads `resource` as `use_`.
    pub fn read(self, resource: ResourceId, use_: BufferUse) -> Self {
        self.frame.graph.decls.push(Decl::Resource(resource, use_, false));
        self
    }

    /// Declares reads of every `(resource, use)` of `reads` (an `Option` reads one or none).
    pub fn reads(mut self, reads: impl IntoIterator<Item = (ResourceId, BufferUse)>) -> Self {
        for (resource, use_) in reads {
            self = self.read(resource, use_);
        }
        self
    }

    /// Declares that the pass writes `resource` as `use_`.
    pub fn write(self, resource: ResourceId, use_: BufferUse) -> Self {
        self.frame.graph.decls.push(Decl::Resource(resource, use_, true));
        self
    }

    /// Declares that the attachment declared last resolves into `target` (single-sampled, depth
    /// if it is depth) at the end of the pass: depth and integer colours take sample 0 (so ids
    /// and depth stay one surface), other colours the mean of the samples.
    pub fn resolve(mut self, target: impl Into<ImageRef>) -> Self {
        let source = self.frame.graph.decls.iter().rev().find_map(|d| match *d {
            Decl::Image(ImageRef::Id(id), use_) if use_.is_attachment() => Some(id),
            _ => None,
        });
        let target = target.into();
        let kinds = source.zip(self.frame.graph.image_id(self.frame.ctx, target).ok()).map(|(s, t)| {
            let images = &self.frame.graph.images;
            (images[s.0 as usize].depth, images[t.0 as usize].depth)
        });
        match (source, kinds) {
            (Some(id), Some((a, b))) if a == b => self.frame.graph.decls.push(Decl::Image(ImageRef::Id(id), ImageUse::ResolveSource)),
            _ => {
                let e = RenderError::Other(format!("pass `{}` resolves into a target unlike the attachment declared last", self.name));
                self.error = self.error.or(Some(e));
            }
        }
        self.image(target, ImageUse::Resolve)
    }

    /// Renders (and clears) only `area`, from the attachments' top-left corner, instead of
    /// their whole extent (a partly used atlas).
    pub fn area(mut self, area: vk::Extent2D) -> Self {
        self.area = Some(area);
        self
    }

    /// Applies `declare` when `condition` holds (an optional declaration in a chain).
    pub fn when(self, condition: bool, declare: impl FnOnce(Self) -> Self) -> Self {
        if condition { declare(self) } else { self }
    }

    /// Declares that the pass's copies fill new images belonging to `resource` (textures): they
    /// are moved into TRANSFER_DST before the pass, and made sampleable for the first pass that
    /// reads `resource` afterwards.
    pub fn upload_images(self, resource: ResourceId, images: impl IntoIterator<Item = (vk::Image, vk::ImageSubresourceRange)>) -> Self {
        self.frame.graph.resources[resource.0 as usize].fresh_images.extend(images);
        self.write(resource, BufferUse::Transfer)
    }

    /// Declares that the pass writes new images belonging to `resource` as storage images (the
    /// environment's cubes): they are moved from UNDEFINED to GENERAL before the pass and stay
    /// there, written as storage and sampled, with `resource`'s barriers ordering the uses.
    pub fn storage_images(self, resource: ResourceId, images: impl IntoIterator<Item = (vk::Image, vk::ImageSubresourceRange)>) -> Self {
        self.frame.graph.resources[resource.0 as usize].general_images.extend(images);
        self.write(resource, BufferUse::Storage)
    }

    /// Records the pass: the derived barriers, the timer, the rendering scope of its attachments
    /// (if any), then `body`.
    pub fn record<R>(self, body: impl FnOnce(&mut PassContext) -> R) -> Result<R, RenderError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let f = self.frame;
        let (ctx, cmd) = (f.ctx, f.cmd);
        // The pass's time includes its barriers (the wait for what it depends on).
        f.timer.begin(cmd, self.name);
        f.graph.emit_barriers(cmd, self.kind);
        let graph = &mut *f.graph;
        let mut extent = graph.extent;
        let mut depth = None;
        graph.colors.clear();
        for decl in &graph.decls {
            let Decl::Image(ImageRef::Id(id), use_) = *decl else { continue };
            let e = &graph.images[id.0 as usize];
            let layout = use_.access(self.kind, e.depth).layout;
            if use_ == ImageUse::Resolve {
                // Into the attachment declared last (`PassBuilder::resolve`).
                let sample_zero = e.depth || e.desc.is_some_and(|d| is_integer(d.format));
                let mode = if sample_zero { vk::ResolveModeFlags::SAMPLE_ZERO } else { vk::ResolveModeFlags::AVERAGE };
                let source = if e.depth { depth.as_mut() } else { graph.colors.last_mut() };
                if let Some(info) = source {
                    *info = info.resolve_mode(mode).resolve_image_view(e.view).resolve_image_layout(layout);
                }
                continue;
            }
            if !use_.is_attachment() {
                continue;
            }
            extent = e.extent;
            let mut info = attachment(e.view, layout, use_);
            if e.desc.is_some_and(|d| d.usage.contains(vk::ImageUsageFlags::TRANSIENT_ATTACHMENT)) {
                // A transient attachment's contents end with the pass (MSAA's radiance, of which
                // only the resolve is kept): not stored.
                info = info.store_op(vk::AttachmentStoreOp::DONT_CARE);
            }
            if e.depth { depth = Some(info) } else { graph.colors.push(info) }
        }
        let extent = self.area.unwrap_or(extent);
        let rendering = depth.is_some() || !graph.colors.is_empty();
        let mut p = PassContext { ctx, cmd, layout: f.layout, bindless: f.bindless, push: f.push, extent };
        if rendering {
            p.begin_rendering(&graph.colors, depth.as_ref());
        }
        let result = body(&mut p);
        if rendering {
            p.end_rendering();
        }
        f.timer.end(cmd);
        Ok(result)
    }
}

fn attachment(view: vk::ImageView, layout: vk::ImageLayout, use_: ImageUse) -> vk::RenderingAttachmentInfo<'static> {
    let load = match use_ {
        ImageUse::Color(load) | ImageUse::DepthWrite(load) => load,
        _ => Load::Keep,
    };
    let (load_op, clear) = match load {
        Load::Keep => (vk::AttachmentLoadOp::LOAD, vk::ClearValue::default()),
        Load::Discard => (vk::AttachmentLoadOp::DONT_CARE, vk::ClearValue::default()),
        Load::Clear(c) => (vk::AttachmentLoadOp::CLEAR, vk::ClearValue { color: vk::ClearColorValue { float32: c } }),
        Load::ClearDepth(d) => {
            // All 16 bytes defined (the depth value fills 8): the frame's command log copies
            // them whole (`crate::gpu::commands`).
            let mut value = vk::ClearValue::default();
            value.depth_stencil = vk::ClearDepthStencilValue { depth: d, stencil: 0 };
            (vk::AttachmentLoadOp::CLEAR, value)
        }
    };
    debug_assert!(
        !matches!(use_, ImageUse::Color(Load::ClearDepth(_)) | ImageUse::DepthWrite(Load::Clear(_))),
        "a colour attachment clears with Load::Clear, a depth attachment with Load::ClearDepth"
    );
    // A read-only attachment is not stored: STORE would count as a write the graph does not
    // track (the store happens at the late fragment tests).
    let store_op = if matches!(use_, ImageUse::DepthTest | ImageUse::DepthTestSampled) {
        vk::AttachmentStoreOp::NONE
    } else {
        vk::AttachmentStoreOp::STORE
    };
    vk::RenderingAttachmentInfo::default().image_view(view).image_layout(layout).load_op(load_op).store_op(store_op).clear_value(clear)
}

impl FrameGraph {
    /// Destroys every target the graph owns; the GPU must be idle.
    pub fn destroy(mut self, ctx: &GpuContext) {
        self.destroy_retired(ctx);
        for e in self.images {
            if let Some(image) = e.owned {
                image.destroy(ctx);
            }
        }
    }
}

/// Makes a readback copy visible to the host, which reads it after the fence (the one barrier
/// the graph places without a declaration).
fn copy_visible_to_host(cmd: &Recorder) {
    let host = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::HOST)
        .dst_access_mask(vk::AccessFlags2::HOST_READ)];
    cmd.barrier(&host, &[]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};

    #[test]
    fn a_read_waits_for_the_last_write_once_per_stage() {
        let mut t = Track::default();
        assert!(t.depend(S::COPY, A::TRANSFER_WRITE, true, false).is_none(), "a first write waits for nothing");
        let d = t.depend(S::FRAGMENT_SHADER, A::SHADER_STORAGE_READ, false, false).expect("read after write");
        assert_eq!((d.src_stages, d.src_access), (S::COPY, A::TRANSFER_WRITE));
        assert!(t.depend(S::FRAGMENT_SHADER, A::SHADER_STORAGE_READ, false, false).is_none(), "already visible");
        let d = t.depend(S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, false, false).expect("a new stage");
        assert_eq!(d.dst_stages, S::COMPUTE_SHADER);
    }

    #[test]
    fn a_write_waits_for_every_read_since_the_last_write() {
        let mut t = Track::default();
        t.depend(S::COPY, A::TRANSFER_WRITE, true, false);
        t.depend(S::FRAGMENT_SHADER, A::SHADER_STORAGE_READ, false, false);
        t.depend(S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, false, false);
        let d = t.depend(S::COPY, A::TRANSFER_WRITE, true, false).expect("write after read");
        assert_eq!(d.src_stages, S::COPY | S::FRAGMENT_SHADER | S::COMPUTE_SHADER);
        assert_eq!(d.src_access, A::TRANSFER_WRITE);
    }

    #[test]
    fn a_layout_transition_is_ordered_like_a_write() {
        let mut t = Track::default();
        assert!(t.depend(S::FRAGMENT_SHADER, A::SHADER_SAMPLED_READ, false, true).is_some(), "a transition always needs a barrier");
        assert!(t.depend(S::FRAGMENT_SHADER, A::SHADER_SAMPLED_READ, false, false).is_none());
        let d = t.depend(S::COMPUTE_SHADER, A::SHADER_SAMPLED_READ, false, false).expect("chained on the transition");
        assert_eq!(d.src_stages, S::FRAGMENT_SHADER);
    }
}
