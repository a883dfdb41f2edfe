//! What a pass's body gets: the device, the frame's commands (`crate::gpu::commands`), the shared pipeline
//! layout with its push constants and the render area; plus the helpers passes share (binding,
//! full-screen triangles).

use ash::vk;

use crate::gpu::commands::Recorder;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::ScenePush;

/// What a pass's body records with: the device, the command buffer, the shared pipeline layout
/// with its push constants, and the render area of the pass's attachments.
pub struct PassContext<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    /// The frame's commands (`crate::gpu::commands`).
    pub cmd: &'a Recorder<'a>,
    /// The layout shared by all pipelines.
    pub layout: vk::PipelineLayout,
    /// The bindless set.
    pub bindless: vk::DescriptorSet,
    /// Push constants for scene passes.
    pub push: ScenePush,
    /// The render area (the attachments' size; the targets' size for passes without any).
    pub extent: vk::Extent2D,
}

impl PassContext<'_> {
    /// Binds the mesh pool as the vertex and index buffer of a mesh pass (`pool`: the scene's
    /// `GpuScene::pool_buffer` this frame, which lives until the frame completes).
    pub fn bind_mesh_pool(&self, pool: vk::Buffer) {
        self.cmd.bind_geometry(pool, 0, 0, vk::IndexType::UINT32);
    }

    /// Binds a graphics pipeline with the bindless set and push constants.
    pub fn bind_graphics(&self, pipeline: vk::Pipeline, push: &ScenePush) {
        self.bind(vk::PipelineBindPoint::GRAPHICS, pipeline, push);
    }

    /// Binds a pipeline at `point` with the bindless set and push constants.
    pub fn bind(&self, point: vk::PipelineBindPoint, pipeline: vk::Pipeline, push: &ScenePush) {
        self.cmd.bind_pipeline(point, pipeline);
        self.cmd.bind_set(point, self.layout, self.bindless);
        self.set_push(push);
    }

    /// Sets the push constants alone (the pipeline bound stays): the steps of a chain that
    /// differ only in them.
    pub fn set_push(&self, push: &ScenePush) {
        self.cmd.push_constants(self.layout, vk::ShaderStageFlags::ALL, 0, bytemuck::bytes_of(push));
    }

    /// Makes what this pass's compute dispatches wrote so far visible to its next dispatch (a
    /// chain of dispatches in one pass, each reading what the one before wrote: the levels of a
    /// pyramid). Storage accesses only (a step that samples what the one before wrote needs a
    /// pass of its own). The graph orders passes; this orders the steps inside one.
    pub fn compute_to_compute(&self) {
        let barrier = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE)];
        self.cmd.barrier(&barrier, &[]);
    }

    /// Begins dynamic rendering into the given attachments over the pass's extent (the graph
    /// calls this from the pass's attachment declarations).
    pub(crate) fn begin_rendering(&self, colors: &[vk::RenderingAttachmentInfo], depth: Option<&vk::RenderingAttachmentInfo>) {
        let extent = self.extent;
        // The attachments' views are live and in the layouts the graph's barriers just put them
        // in.
        self.cmd.begin_rendering(extent, colors, depth);
        crate::gpu::pipeline::set_viewport(self.cmd, extent);
        // Every pipeline has viewport, scissor and cull mode dynamic; this sets the last of the
        // three before any draw.
        self.cmd.set_cull_mode(vk::CullModeFlags::NONE);
    }

    /// Binds `pipeline` with `push` and draws one full-screen triangle.
    pub fn fullscreen(&self, pipeline: vk::Pipeline, push: &ScenePush) {
        self.bind_graphics(pipeline, push);
        self.cmd.draw(3, 1, 0, 0);
    }

    /// Ends dynamic rendering.
    pub(crate) fn end_rendering(&self) {
        self.cmd.end_rendering();
    }
}
