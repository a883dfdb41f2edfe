//! Deferred shading (seed 000 §2.6, §5.1.2): a geometry pass writes material attributes into the
//! G-buffer, optional deferred decals (§3.2, §5.1.2.1) alpha-blend into it, and one full-screen
//! lighting pass applies ray-query decals (when they are the method) and every light.
//!
//! Decal normals: the seed transformed deferred decals' normals with the decal's
//! inverse-transpose and notes that this is wrong when the decal is oriented unlike the surface.
//! Instead of storing a compressed tangent frame in the G-buffer to fix that, we build the frame
//! the decal's normal map is read in from the decal's own axes projected onto the surface normal
//! (`shaders/include/decals.glsl`), which is right for any orientation and needs only the normal
//! the G-buffer already holds: the fix costs no G-buffer bytes. (Ray-query decals in the lighting
//! pass use the normal-mapped G-buffer normal; deferred decals, which cannot read the normal
//! target while blending into it, use the geometric normal reconstructed from depth.)
//!
//! The G-buffer's formats and the reasons for them are in `shaders/gbuffer.frag` (11 bytes a
//! pixel beside depth and the HDR target). Deferred
//! decals are drawn in channel-then-weight order as runs of instanced boxes; each run shares the
//! decal material's set of attributes, which selects one of 16 pipelines whose write masks touch
//! only those attributes.

use ash::vk;

use crate::RenderError;
use crate::device::{GpuContext, Tier};
use crate::gpu_scene::GpuScene;
use crate::pass::{PassContext, color_attachment, depth_attachment};
use crate::pipeline::{Blend, GraphicsDesc, create_graphics};
use crate::scene::{DECAL_ALBEDO, DECAL_METALLIC, DECAL_NORMAL, DECAL_ROUGHNESS, DrawItem, GpuDecal, GpuDecalMaterial};
use crate::shaders;
use crate::sync::Access;
use crate::targets::{
    DEPTH_FORMAT, GBUFFER_ALBEDO_FORMAT, GBUFFER_LAYERS_FORMAT, GBUFFER_MATERIAL_FORMAT, GBUFFER_NORMAL_FORMAT, HDR_FORMAT, Targets,
};

/// A run of consecutive decals in draw order that change the same attributes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalRun {
    /// Index of the run's first decal in the draw order.
    pub first: u32,
    /// Decals in the run.
    pub count: u32,
    /// `DECAL_*` flags of the run.
    pub flags: u32,
}

/// Sorts the live decals of `records` by channel, then weight (then slot, for stability) into
/// `slots`, and splits them into `runs` of equal attribute sets. `keys` is scratch space.
pub fn plan_deferred_decals(
    records: &[GpuDecal],
    materials: &[GpuDecalMaterial],
    keys: &mut Vec<(u32, f32, u32)>,
    slots: &mut Vec<u32>,
    runs: &mut Vec<DecalRun>,
) {
    keys.clear();
    keys.extend(records.iter().enumerate().filter(|(_, r)| r.receivers != 0).map(|(i, r)| (r.channel, r.weight, i as u32)));
    keys.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
    slots.clear();
    slots.extend(keys.iter().map(|k| k.2));
    runs.clear();
    for (i, &slot) in slots.iter().enumerate() {
        let flags = materials.get(records[slot as usize].material as usize).map_or(0, |m| m.flags & 15);
        match runs.last_mut() {
            Some(run) if run.flags == flags => run.count += 1,
            _ => runs.push(DecalRun { first: i as u32, count: 1, flags }),
        }
    }
}

/// Pipelines of the deferred renderer.
pub struct DeferredPasses {
    gbuffer_opaque: vk::Pipeline,
    gbuffer_mask: vk::Pipeline,
    lighting: vk::Pipeline,
    /// Indexed by `DECAL_*` flags (0..16).
    decals: Vec<vk::Pipeline>,
}

const GBUFFER_FORMATS: [vk::Format; 5] =
    [GBUFFER_ALBEDO_FORMAT, GBUFFER_NORMAL_FORMAT, GBUFFER_MATERIAL_FORMAT, GBUFFER_LAYERS_FORMAT, HDR_FORMAT];

impl DeferredPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let geometry = GraphicsDesc::mesh("gbuffer", Some(shaders::GBUFFER_FRAG), &GBUFFER_FORMATS);
        let hdr = [HDR_FORMAT];
        let lighting_fs =
            if ctx.tier == Tier::RayQuery { shaders::DEFERRED_LIGHTING_FRAG_RAY_QUERY_DECALS } else { shaders::DEFERRED_LIGHTING_FRAG };
        let mut lighting = GraphicsDesc::fullscreen("deferred lighting", lighting_fs, &hdr);
        lighting.blend = Blend::Additive;
        let decal_formats = [GBUFFER_ALBEDO_FORMAT, GBUFFER_NORMAL_FORMAT, GBUFFER_MATERIAL_FORMAT];
        let mut decals = Vec::with_capacity(16);
        for flags in 0..16u32 {
            use vk::ColorComponentFlags as C;
            let rgb = C::R | C::G | C::B;
            let masks = [
                if flags & DECAL_ALBEDO != 0 { rgb } else { C::empty() },
                if flags & DECAL_NORMAL != 0 { rgb } else { C::empty() },
                (if flags & DECAL_ROUGHNESS != 0 { C::R } else { C::empty() })
                    | (if flags & DECAL_METALLIC != 0 { C::G } else { C::empty() }),
            ];
            decals.push(create_graphics(
                ctx,
                layout,
                &GraphicsDesc {
                    name: "deferred decals",
                    vertex: shaders::DECAL_BOX_VERT,
                    fragment: Some(shaders::DEFERRED_DECAL_FRAG),
                    mesh_vertices: false,
                    color_formats: &decal_formats,
                    // Front faces tested against the scene's depth (read-only): boxes hidden
                    // behind other geometry cost nothing. Boxes the camera is inside are drawn
                    // inside-out at the near plane instead (shaders/decal_box.vert).
                    depth_format: Some(DEPTH_FORMAT),
                    depth_compare: Some(vk::CompareOp::GREATER_OR_EQUAL),
                    depth_write: false,
                    topology: vk::PrimitiveTopology::TRIANGLE_LIST,
                    blend: Blend::Alpha,
                    write_masks: &masks,
                },
            )?);
        }
        Ok(Self {
            gbuffer_opaque: create_graphics(ctx, layout, &geometry)?,
            gbuffer_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::GBUFFER_FRAG_ALPHA_MASK), ..geometry })?,
            lighting: create_graphics(ctx, layout, &lighting)?,
            decals,
        })
    }

    /// Geometry pass: depth and every attribute, emitted radiance into the HDR target.
    pub fn geometry(&self, p: &mut PassContext, targets: &mut Targets, scene: &GpuScene, draws: &[Option<DrawItem>], clear: [f32; 4]) {
        let Targets { extent, hdr, depth, gbuffer, .. } = targets;
        let g = gbuffer.as_mut().expect("created by the renderer before recording");
        p.timed("gbuffer", |p| {
            depth.overwrite_as(p.ctx, p.cmd, Access::DepthAttachmentWrite);
            for t in [&mut g.albedo, &mut g.normal, &mut g.material, &mut g.layers, &mut *hdr] {
                t.overwrite_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            }
            let colors = [
                color_attachment(g.albedo.image.view, Some([0.0; 4])),
                color_attachment(g.normal.image.view, Some([0.5, 0.5, 1.0, 1.0])),
                color_attachment(g.material.image.view, Some([0.0; 4])),
                color_attachment(g.layers.image.view, Some([0.0; 4])),
                color_attachment(hdr.image.view, Some(clear)),
            ];
            let depth_info = depth_attachment(depth.image.view, Access::DepthAttachmentWrite.layout(), Some(0.0));
            p.begin_rendering(*extent, &colors, Some(&depth_info));
            let push = p.push;
            p.bind_graphics(self.gbuffer_opaque, &push);
            p.draw_meshes(scene, draws, |d| !d.alpha_mask);
            p.bind_graphics(self.gbuffer_mask, &push);
            p.draw_meshes(scene, draws, |d| d.alpha_mask);
            p.end_rendering();
        });
    }

    /// Deferred decals: the boxes of `runs`, blended into the G-buffer.
    pub fn decals(&self, p: &mut PassContext, targets: &mut Targets, runs: &[DecalRun]) {
        if runs.is_empty() {
            return;
        }
        let Targets { extent, depth, gbuffer, .. } = targets;
        let g = gbuffer.as_mut().expect("created by the renderer before recording");
        p.timed("deferred_decals", |p| {
            depth.use_as(p.ctx, p.cmd, Access::DepthSampled);
            g.layers.use_as(p.ctx, p.cmd, Access::FragmentSampled);
            for t in [&mut g.albedo, &mut g.normal, &mut g.material] {
                t.use_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            }
            let colors = [
                color_attachment(g.albedo.image.view, None),
                color_attachment(g.normal.image.view, None),
                color_attachment(g.material.image.view, None),
            ];
            let depth_info = depth_attachment(depth.image.view, Access::DepthSampled.layout(), None);
            p.begin_rendering(*extent, &colors, Some(&depth_info));
            let push = p.push;
            for run in runs {
                p.bind_graphics(self.decals[(run.flags & 15) as usize], &push);
                // SAFETY: `cmd` is recording inside the rendering scope with the pipeline bound;
                // the draw order table holds `first + count` entries.
                unsafe {
                    p.ctx.device.cmd_set_cull_mode(p.cmd, vk::CullModeFlags::BACK);
                    p.ctx.device.cmd_draw(p.cmd, 36, run.count, 0, run.first);
                }
            }
            p.end_rendering();
        });
    }

    /// Lighting: one full-screen pass over the G-buffer, added to the emitted radiance.
    pub fn lighting(&self, p: &mut PassContext, targets: &mut Targets) {
        let Targets { extent, hdr, depth, gbuffer, .. } = targets;
        let g = gbuffer.as_mut().expect("created by the renderer before recording");
        p.timed("lighting", |p| {
            depth.use_as(p.ctx, p.cmd, Access::DepthSampled);
            for t in [&mut g.albedo, &mut g.normal, &mut g.material, &mut g.layers] {
                t.use_as(p.ctx, p.cmd, Access::FragmentSampled);
            }
            hdr.use_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            let colors = [color_attachment(hdr.image.view, None)];
            p.begin_rendering(*extent, &colors, None);
            let push = p.push;
            p.bind_graphics(self.lighting, &push);
            // SAFETY: `cmd` is recording inside the rendering scope with the pipeline bound.
            unsafe { p.ctx.device.cmd_draw(p.cmd, 3, 1, 0, 0) };
            p.end_rendering();
        });
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.gbuffer_opaque, self.gbuffer_mask, self.lighting].into_iter().chain(self.decals) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bytemuck::Zeroable;

    #[test]
    fn decals_are_ordered_by_channel_then_weight_in_runs_of_equal_attributes() {
        let decal = |channel, weight, material| GpuDecal { channel, weight, material, receivers: 1, ..GpuDecal::zeroed() };
        let records = [
            decal(1, 1.0, 0),
            GpuDecal::zeroed(), // a free slot
            decal(0, 2.0, 1),
            decal(0, 0.5, 0),
            decal(1, 0.2, 0),
        ];
        let materials = [
            GpuDecalMaterial { flags: DECAL_ALBEDO, ..GpuDecalMaterial::zeroed() },
            GpuDecalMaterial { flags: DECAL_NORMAL | DECAL_ROUGHNESS, ..GpuDecalMaterial::zeroed() },
        ];
        let (mut keys, mut slots, mut runs) = (Vec::new(), Vec::new(), Vec::new());
        plan_deferred_decals(&records, &materials, &mut keys, &mut slots, &mut runs);
        assert_eq!(slots, vec![3, 2, 4, 0]);
        assert_eq!(
            runs,
            vec![
                DecalRun { first: 0, count: 1, flags: DECAL_ALBEDO },
                DecalRun { first: 1, count: 1, flags: DECAL_NORMAL | DECAL_ROUGHNESS },
                DecalRun { first: 2, count: 2, flags: DECAL_ALBEDO },
            ]
        );
    }
}
