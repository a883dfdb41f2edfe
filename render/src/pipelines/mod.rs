//! The pipelines, one function each, reading as the whole frame from top to bottom: upload what
//! changed, acceleration-structure work, the pipeline's passes, debug overlays, tone mapping and
//! the egui overlay. Every pass is declared on the frame graph ([`crate::graph`]), which derives
//! the barriers between them.

pub mod deferred;
pub mod forward;
pub mod visbuffer;

use crate::RenderError;
use crate::decals::{DecalChoice, DecalFrame, Decals};
use crate::gpu::pipeline::ScenePush;
use crate::graph::Frame;
use crate::present::Present;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::FrameSettings;

/// The renderer's parts a frame function draws with.
pub struct FrameParts<'a> {
    /// The GPU scene (tables, meshes, textures).
    pub scene: &'a mut GpuScene,
    /// Decal acceleration structures, deferred-decal order, debug boxes.
    pub decals: &'a mut Decals,
    /// Forward passes.
    pub forward: &'a forward::ForwardPasses,
    /// Deferred passes.
    pub deferred: &'a deferred::DeferredPasses,
    /// Visibility-buffer passes.
    pub visbuffer: &'a visbuffer::VisBufferPasses,
    /// Tone mapping and overlay into the frame's display image.
    pub present: Present<'a>,
    /// The decal method asked for and the one this device and pipeline apply.
    pub decal_choice: DecalChoice,
}

/// Forward: depth prepass, then shading with depth EQUAL (ray-query decals included).
pub fn forward_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<(), RenderError> {
    r.decals.follow_changes(mirror, r.scene, r.decal_choice);
    let boxes_changed = r.scene.upload(f, mirror)?;
    let decals = r.decals.build_accel(f, r.scene, mirror, r.decal_choice, boxes_changed)?;
    f.push = scene_push(r.scene, mirror, s, &decals);
    r.forward.prepass(f, r.scene, &mirror.draws)?;
    r.forward.shade(f, r.scene, &mirror.draws, s.clear_color, decals.traced)?;
    r.decals.draw_boxes(f, r.scene, mirror, s)?;
    r.present.record(f, r.scene)
}

/// Deferred: G-buffer, deferred decals (when they are the method), full-screen lighting
/// (ray-query decals included when they are).
pub fn deferred_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<(), RenderError> {
    r.decals.follow_changes(mirror, r.scene, r.decal_choice);
    let boxes_changed = r.scene.upload(f, mirror)?;
    let decals = r.decals.build_accel(f, r.scene, mirror, r.decal_choice, boxes_changed)?;
    f.push = scene_push(r.scene, mirror, s, &decals);
    r.deferred.geometry(f, r.scene, &mirror.draws, s.clear_color)?;
    r.deferred.decals(f, r.scene, r.decals.deferred_runs(&decals))?;
    r.deferred.lighting(f, r.scene, decals.traced)?;
    r.decals.draw_boxes(f, r.scene, mirror, s)?;
    r.present.record(f, r.scene)
}

/// Visibility buffer: ids and depth, then one full-screen pass that rebuilds and shades.
pub fn visbuffer_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<(), RenderError> {
    r.decals.follow_changes(mirror, r.scene, r.decal_choice);
    let boxes_changed = r.scene.upload(f, mirror)?;
    let decals = r.decals.build_accel(f, r.scene, mirror, r.decal_choice, boxes_changed)?;
    f.push = scene_push(r.scene, mirror, s, &decals);
    r.visbuffer.visibility(f, r.scene, &mirror.draws)?;
    r.visbuffer.shade(f, r.scene, s.clear_color, decals.traced)?;
    r.decals.draw_boxes(f, r.scene, mirror, s)?;
    r.present.record(f, r.scene)
}

/// The push constants every scene pass of the frame shares.
fn scene_push(scene: &GpuScene, mirror: &SceneMirror, s: &FrameSettings, decals: &DecalFrame) -> ScenePush {
    ScenePush {
        camera: scene.camera.address(),
        instances: scene.instances.address(),
        materials: scene.materials.address(),
        lights: scene.lights.address(),
        decals: scene.decals.address(),
        decal_materials: scene.decal_materials.address(),
        decal_tlas: decals.tlas_address,
        decal_aabbs: scene.decal_aabbs.address(),
        meshes: scene.mesh_table.address(),
        decal_order: scene.decal_order.address(),
        light_count: mirror.lights.slot_count(),
        texture_index: 0,
        debug_view: s.debug_view as u32,
        decal_count: decals.count,
    }
}
