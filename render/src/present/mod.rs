//! Getting the frame to the eye: tone mapping (and post-process anti-aliasing) into the display image (the offscreen display
//! target or a swapchain image), the egui overlay on top, and the window swapchain.

pub mod check;
pub mod overlay;
pub mod tonemap;
pub mod window;

use crate::RenderError;
use crate::graph::{BufferUse, Frame, ImageRef, Load, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;
use crate::settings::AntiAliasing;
use check::DisplayCheck;
use overlay::{Overlay, OverlayFrame};
use tonemap::Tonemap;

/// The end of a frame: where it goes and what is drawn over it.
pub struct Present<'a> {
    /// The tone mapper for the display image's format.
    pub tonemap: &'a Tonemap,
    /// The display image.
    pub target: ImageRef,
    /// The egui overlay and this frame's primitives, in a window.
    pub overlay: Option<(&'a mut Overlay, &'a OverlayFrame)>,
    /// Anti-aliasing of the displayed image.
    pub aa: AntiAliasing,
    /// The debug builds' check of the tone mapper's input (`None` in release builds).
    pub check: Option<&'a mut DisplayCheck>,
}

impl Present<'_> {
    /// Tone maps the HDR target into the display image (reading auto-exposure's record,
    /// `exposure`, when it runs), then draws the overlay over it.
    pub fn record(&mut self, f: &mut Frame, scene: &GpuScene, exposure: Option<(ResourceId, BufferUse)>) -> Result<(), RenderError> {
        if let Some(check) = self.check.as_deref_mut() {
            check.begin(f)?;
        }
        let check = self.check.as_deref().map(DisplayCheck::writes);
        self.tonemap.record(f, scene, self.target, self.aa, exposure, check)?;
        if let Some(check) = self.check.as_deref_mut() {
            check.finish(f)?;
        }
        if let Some((egui, frame)) = &mut self.overlay {
            f.pass("overlay", PassKind::Graphics)
                .color(self.target, Load::Keep)
                .record(|p| egui.record(p.cmd.direct()?, p.extent, frame))??;
        }
        Ok(())
    }
}
