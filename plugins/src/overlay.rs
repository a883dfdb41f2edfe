//! The egui debug overlay ([`OverlayPlugin`]) the window runner draws: frame time and per-pass GPU
//! times (with a graph of the last seconds), what the scene holds and what the GPU built this
//! frame, and controls for the pipeline, the decal and light methods, shadows and the debug
//! views. F1 hides it. A game adds its own controls and drawings with an [`OverlayExtension`].

use std::collections::VecDeque;

use bevy_ecs::prelude::*;
use engine::app::{App, Plugin};
use render::{DebugView, DecalMethod, PipelineKind};

use crate::{FrameStats, RenderSettings, RenderStats};

/// Frames kept for the graph (about five seconds at 60 Hz).
const HISTORY: usize = 300;

/// A game's additions to the debug overlay.
pub trait OverlayExtension: Send + Sync + 'static {
    /// Draws on the screen every frame, whether the overlay window is shown or not (a
    /// crosshair, say).
    fn paint(&mut self, _ctx: &egui::Context, _world: &mut World) {}
    /// Adds controls at the end of the overlay window.
    fn controls(&mut self, _ui: &mut egui::Ui, _world: &mut World) {}
}

/// Draws the debug overlay over the window ([`crate::window::WindowPlugin`]; headless apps have
/// nothing to draw it on).
#[derive(Default)]
pub struct OverlayPlugin {
    extensions: std::sync::Mutex<Vec<Box<dyn OverlayExtension>>>,
}

impl OverlayPlugin {
    /// The overlay with `extension`'s drawings and controls added.
    pub fn with(self, extension: impl OverlayExtension) -> Self {
        self.extensions.lock().expect("not poisoned").push(Box::new(extension));
        self
    }
}

impl Plugin for OverlayPlugin {
    fn build(&self, app: &mut App) {
        let extensions = std::mem::take(&mut *self.extensions.lock().expect("not poisoned"));
        app.insert_resource(DebugOverlay { extensions, ..Default::default() });
    }
}

/// State of the overlay between frames.
#[derive(Resource)]
pub struct DebugOverlay {
    /// Whether the overlay window is drawn (F1 toggles it).
    pub visible: bool,
    history: VecDeque<FrameStats>,
    frame_ms: VecDeque<f32>,
    /// The first frame not yet taken into `history`.
    next_frame: u64,
    extensions: Vec<Box<dyn OverlayExtension>>,
}

impl Default for DebugOverlay {
    fn default() -> Self {
        Self {
            visible: true,
            history: VecDeque::with_capacity(HISTORY),
            frame_ms: VecDeque::with_capacity(HISTORY),
            next_frame: 0,
            extensions: Vec::new(),
        }
    }
}

impl DebugOverlay {
    /// Records the CPU frame time and copies the statistics of frames finished since the last
    /// call (leaving them in [`RenderStats::completed`] for other readers, such as a stats file).
    pub fn observe(&mut self, world: &mut World, frame_ms: f32) {
        if self.frame_ms.len() == HISTORY {
            self.frame_ms.pop_front();
        }
        self.frame_ms.push_back(frame_ms);
        let stats = world.resource::<RenderStats>();
        let next = self.next_frame;
        for s in stats.completed.iter().filter(|s| s.frame >= next) {
            if self.history.len() == HISTORY {
                self.history.pop_front();
            }
            self.history.push_back(*s);
            self.next_frame = s.frame + 1;
        }
    }

    /// Draws the overlay and applies what the user changed; the extensions' drawings always.
    pub fn show(&mut self, ctx: &egui::Context, world: &mut World) {
        for e in &mut self.extensions {
            e.paint(ctx, world);
        }
        if !self.visible {
            return;
        }
        // Collapsed to the frame time and its graph, so that the game stays visible (a small
        // corner of a 1280×720 window); each section opens on a click.
        egui::Window::new("ecs-decals").default_pos([12.0, 12.0]).resizable(false).show(ctx, |ui| {
            self.summary(ui);
            egui::CollapsingHeader::new("timings").default_open(false).show(ui, |ui| self.timings(ui));
            egui::CollapsingHeader::new("scene and work").default_open(false).show(ui, |ui| self.counts(ui, world));
            egui::CollapsingHeader::new("GPU memory").default_open(false).show(ui, |ui| memory(ui, world));
            egui::CollapsingHeader::new("settings").default_open(false).show(ui, |ui| {
                self.controls(ui, world);
                for e in &mut self.extensions {
                    e.controls(ui, world);
                }
            });
            ui.small("F1 hides this overlay");
        });
    }

    /// The frame time and the graph of the last seconds: what the collapsed overlay shows.
    fn summary(&self, ui: &mut egui::Ui) {
        let frame = self.frame_ms.back().copied().unwrap_or(0.0);
        let gpu = self.history.back().map_or(String::new(), |s| format!(", GPU {:.2} ms", s.gpu.total_ms));
        ui.label(format!("frame {frame:.2} ms ({:.0} fps){gpu}", if frame > 0.0 { 1000.0 / frame } else { 0.0 }));
        // A small graph of frame time (white) and GPU time (green) over the last seconds.
        let (rect, _) = ui.allocate_exact_size(egui::vec2(260.0, 60.0), egui::Sense::hover());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 2.0, egui::Color32::from_black_alpha(120));
        let max = self.frame_ms.iter().copied().fold(16.7f32, f32::max);
        let plot = |values: &mut dyn Iterator<Item = f32>, count: usize, colour: egui::Color32| {
            let points: Vec<egui::Pos2> = values
                .enumerate()
                .map(|(i, v)| {
                    let x = rect.left()
                        + rect.width() * i as f32 / (HISTORY - 1) as f32
                        + rect.width() * (HISTORY - count) as f32 / HISTORY as f32;
                    egui::pos2(x, rect.bottom() - rect.height() * (v / max).min(1.0))
                })
                .collect();
            painter.add(egui::Shape::line(points, egui::Stroke::new(1.0, colour)));
        };
        plot(&mut self.frame_ms.iter().copied(), self.frame_ms.len(), egui::Color32::WHITE);
        plot(&mut self.history.iter().map(|s| s.gpu.total_ms), self.history.len(), egui::Color32::LIGHT_GREEN);
        ui.small(format!("graph: frame (white) and GPU (green) time, top = {max:.1} ms"));
    }

    /// The GPU time of each pass and the CPU time of each part of the last finished frame.
    fn timings(&self, ui: &mut egui::Ui) {
        if let Some(last) = self.history.back() {
            let passes: Vec<String> = last.gpu.iter().map(|(name, ms)| format!("{name} {ms:.2}")).collect();
            ui.label(format!("GPU {:.2} ms: {}", last.gpu.total_ms, passes.join(", ")));
            ui.label(format!(
                "CPU {:.2} ms a frame{} (GPU waits excluded): animate {:.2}, propagate {:.2}, skin {:.2}, extract {:.2}, record {:.2} (of it prepare {:.2}, submit {:.2}); visited {} instances, {} lights, {} decals",
                last.cpu_frame_ms,
                if last.pipelined { " on the main thread, recording on the render thread" } else { "" },
                last.cpu_animate_ms,
                last.cpu_propagate_ms,
                last.cpu_skin_ms,
                last.cpu_extract_ms,
                last.cpu_record_ms,
                last.cpu_prepare_ms,
                last.cpu_submit_ms,
                last.visited.instances,
                last.visited.lights,
                last.visited.decals
            ));
        }
    }

    fn counts(&self, ui: &mut egui::Ui, world: &World) {
        let c = world.resource::<RenderStats>().last;
        ui.label(format!("instances {}   lights {}   decals {}", c.instances, c.lights, c.decals));
        if c.particles.capacity > 0 {
            let p = c.particles;
            ui.label(format!(
                "particles {} alive of {}   {} started, {} landed, {} dropped, {} decals left (frame {})",
                p.alive, p.capacity, p.spawned, p.landed, p.dropped, p.decals_born, p.measured_frame
            ));
        }
        // What the GPU applied, which may differ from the request (a device without ray queries).
        if let Some(last) = self.history.back() {
            ui.label(format!(
                "decals applied: {} (surface: {})   lights: {}{}   shadows: {} (direct light: {})   ambient occlusion: {}",
                last.decal_method.name(),
                last.decal_surface.map_or("none", |s| s.name()),
                last.light_method.name(),
                if last.staged_lights { ", lists staged" } else { "" },
                last.shadows.name(),
                last.direct_light.map_or("none", |d| d.name()),
                last.occlusion.name()
            ));
        }
        ui.label(format!(
            "this frame: decal BLAS builds {}, refits {}, TLAS builds {}; scene BLAS builds {}, TLAS builds {}, updates {}; light BLAS builds {}, refits {}; {} bytes uploaded",
            c.blas_builds,
            c.blas_updates,
            c.tlas_builds,
            c.scene_blas_builds,
            c.scene_tlas_builds,
            c.scene_tlas_updates,
            c.light_blas_builds,
            c.light_blas_updates,
            c.bytes_uploaded
        ));
        if c.skinned_meshes > 0 || c.scene_blas_refits > 0 {
            ui.label(format!(
                "skinning: {} meshes, {} vertices; scene BLAS refits {}, deferred {} (stalest {} frames behind)",
                c.skinned_meshes, c.skinned_vertices, c.scene_blas_refits, c.scene_blas_refits_deferred, c.scene_blas_stalest
            ));
        }
        let k = c.culling;
        let measured = if k.measured_frame == u64::MAX {
            "not measured yet".to_string()
        } else {
            format!(
                "{} tested, {} in the frustum, {} drawn ({} triangles; by level of detail {:?})",
                k.instances, k.after_frustum, k.after_occlusion, k.triangles, k.lod_instances
            )
        };
        ui.label(format!("culling {}{}: {measured}; {} draw calls", k.mode.name(), if k.frozen { " (frozen)" } else { "" }, c.draw_calls));
    }

    fn controls(&mut self, ui: &mut egui::Ui, world: &mut World) {
        let mut settings = world.resource_mut::<RenderSettings>();
        egui::ComboBox::from_label("pipeline").selected_text(settings.pipeline.name()).show_ui(ui, |ui| {
            for p in PipelineKind::ALL {
                ui.selectable_value(&mut settings.pipeline, p, p.name());
            }
        });
        egui::ComboBox::from_label("decals").selected_text(settings.decal_method.name()).show_ui(ui, |ui| {
            for m in DecalMethod::ALL {
                ui.selectable_value(&mut settings.decal_method, m, m.name());
            }
        });
        let views = [
            (DebugView::Lit, "lit"),
            (DebugView::DecalHeatmap, "decal heat map"),
            (DebugView::Albedo, "albedo"),
            (DebugView::Normal, "normal"),
            (DebugView::RoughnessMetallic, "roughness/metallic"),
            (DebugView::LightHeatmap, "lights per tile"),
            (DebugView::ShadowRays, "shadow rays"),
            (DebugView::DepthNormals, "normals from depth"),
            (DebugView::Reflections, "reflection rays"),
            (DebugView::AmbientOcclusion, "ambient occlusion"),
            (DebugView::Lod, "level of detail"),
        ];
        let current = views.iter().find(|(v, _)| *v == settings.debug_view).map_or("lit", |(_, n)| n);
        egui::ComboBox::from_label("view").selected_text(current).show_ui(ui, |ui| {
            for (v, name) in views {
                ui.selectable_value(&mut settings.debug_view, v, name);
            }
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut settings.show_decal_boxes, "decal boxes");
            ui.checkbox(&mut settings.decals_in_forward_shading, "decals in shading")
                .on_hover_text("forward and Forward+ walk clustered decals' lists in their shading pass (no decal pass, no ids prepass)");
            for m in render::AntiAliasing::ALL {
                ui.selectable_value(&mut settings.aa, m, format!("AA {}", m.name()));
            }
            if settings.aa == render::AntiAliasing::Taa {
                ui.add(egui::Slider::new(&mut settings.taa_sharpen, 0.0..=1.0).text("sharpen"));
            }
        });
        ui.horizontal(|ui| {
            ui.label("tone map");
            for t in render::Tonemapper::ALL {
                ui.selectable_value(&mut settings.tonemapper, t, t.name());
            }
            ui.checkbox(&mut settings.bloom.enabled, "bloom");
            ui.add(egui::Slider::new(&mut settings.bloom.intensity, 0.0..=0.3).text("intensity"));
        });
        ui.horizontal(|ui| {
            ui.label("ambient occlusion");
            for m in render::OcclusionMethod::ALL {
                ui.selectable_value(&mut settings.occlusion.method, m, m.name());
            }
            ui.add(egui::Slider::new(&mut settings.occlusion.radius, 0.1..=4.0).text("radius (m)"));
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut settings.exposure.enabled, "auto-exposure");
            ui.add(egui::Slider::new(&mut settings.exposure.compensation, -4.0..=4.0).text("compensation (stops)"));
        });
        ui.horizontal(|ui| {
            ui.label("reflections");
            for m in render::ReflectionMode::ALL {
                ui.selectable_value(&mut settings.reflections.mode, m, m.name());
            }
            ui.checkbox(&mut settings.reflections.half_resolution, "half res");
        });
        ui.horizontal(|ui| {
            for m in render::LightMethod::ALL {
                ui.selectable_value(&mut settings.lights.method, m, m.name());
            }
            for t in [8, 16, 32] {
                ui.selectable_value(&mut settings.lights.tile_size, t, format!("{t}px"));
            }
        });
        ui.horizontal(|ui| {
            ui.checkbox(&mut settings.lights.shadows, "shadows");
            for d in render::DirectLight::ALL {
                ui.selectable_value(&mut settings.lights.direct_light, d, d.name());
            }
            ui.checkbox(&mut settings.lights.shadow_ray_culling, "shadow-ray culling");
            ui.checkbox(&mut settings.lights.cull_aabb, "tile AABB");
            ui.checkbox(&mut settings.lights.cull_depth_mask, "tile depth mask");
            ui.checkbox(&mut settings.compute_shading, "compute shading");
        });
        ui.horizontal(|ui| {
            for m in render::TransparencyMethod::ALL {
                ui.selectable_value(&mut settings.transparency, m, m.name());
            }
            ui.checkbox(&mut settings.refraction, "refraction");
        });
        ui.horizontal(|ui| {
            for m in render::CullingMode::ALL {
                ui.selectable_value(&mut settings.culling, m, format!("culling {}", m.name()));
            }
            ui.checkbox(&mut settings.freeze_culling, "freeze culling");
            ui.add(egui::Slider::new(&mut settings.lod_pixels, 0.0..=8.0).text("level-of-detail error (px, 0: off)"));
            ui.add(egui::Slider::new(&mut settings.refit_pixels, 0.0..=256.0).text("characters refit every frame above (px, 0: all)"));
            ui.checkbox(&mut settings.skin_levels, "skin a far character's level of detail only");
            ui.checkbox(&mut settings.pipelined, "record on the render thread (pipelined)");
        });
    }
}

/// GPU memory at the end of the last frame, by what it holds (`render::gpu::memory`), in MiB.
fn memory(ui: &mut egui::Ui, world: &World) {
    let last = &world.resource::<RenderStats>().last;
    let (m, budget) = (last.memory, last.texture_budget);
    let mib = |bytes: u64| bytes as f64 / (1024.0 * 1024.0);
    ui.label(format!("{:.1} MiB in all", mib(m.total())));
    if budget.budget > 0 {
        ui.label(format!(
            "scene textures {:.1} of a {:.1} MiB budget; {} finest levels ({:.1} MiB) dropped to fit",
            mib(budget.resident),
            mib(budget.budget),
            budget.levels_dropped,
            mib(budget.bytes_dropped)
        ));
    }
    for kind in render::gpu::memory::MemoryKind::ALL {
        ui.label(format!("{}: {:.1} MiB", kind.name().replace('_', " "), mib(m.of(kind))));
        if kind == render::gpu::memory::MemoryKind::MeshPool && last.posed_mesh_bytes > 0 {
            ui.label(format!("   of which posed copies: {:.1} MiB", mib(last.posed_mesh_bytes)));
        }
    }
    for (format, bytes) in m.texture_formats() {
        ui.label(format!("   textures {format:?}: {:.1} MiB", mib(bytes)));
    }
}
