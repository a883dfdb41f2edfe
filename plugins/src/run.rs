//! Running an app without a window, and choosing between a window and no window from the
//! command line: what the examples (and a game's own smoke tests) use.
//!
//! - [`HeadlessPlugin`]: `app.run()` renders a number of frames offscreen, optionally writes the
//!   last one as a PNG, and fails on a rendering error or a Vulkan validation error.
//! - [`RunPlugin::from_args`]: a window ([`crate::window::WindowPlugin`]) unless the command line
//!   says `--headless` or no display is reachable; `--frames N`, `--size WxH`,
//!   `--screenshot PATH` and `--click X,Y` (a left click at that pixel, repeatable) set the
//!   headless run.

use std::path::PathBuf;

use engine::app::{App, Plugin, RunResult};
use engine::input::{Input, MouseButton};

use crate::window::{WindowPlugin, display_available};
use crate::{GpuRenderer, RenderSettings, RenderStats, finish_frames};

/// Makes `app.run()` render `frames` frames offscreen (fewer when a system inserts
/// [`engine::app::AppExit`]), then write the last as a PNG to `screenshot` when set. Fails when
/// a frame failed, the renderer could not start, or Vulkan validation reported an error.
#[derive(Clone, Debug)]
pub struct HeadlessPlugin {
    /// Frames to render.
    pub frames: u32,
    /// Where to write the last frame (PNG).
    pub screenshot: Option<PathBuf>,
    /// Render at this size instead of [`RenderSettings::size`].
    pub size: Option<(u32, u32)>,
    /// Left clicks at these pixels, one every other frame from frame 2, fed into
    /// [`engine::input::Input`] as a window would (scripted play for demos and smoke tests).
    pub clicks: Vec<glam::Vec2>,
}

impl Default for HeadlessPlugin {
    fn default() -> Self {
        Self { frames: 60, screenshot: None, size: None, clicks: Vec::new() }
    }
}

impl Plugin for HeadlessPlugin {
    fn build(&self, app: &mut App) {
        let this = self.clone();
        app.set_runner(move |app| this.run(app));
    }
}

impl HeadlessPlugin {
    fn run(&self, mut app: App) -> RunResult {
        if let (Some(size), Some(mut settings)) = (self.size, app.world.get_resource_mut::<RenderSettings>()) {
            settings.size = size;
        }
        for frame in 0..self.frames {
            let click = frame.checked_sub(2).filter(|f| f % 2 == 0).and_then(|f| self.clicks.get(f as usize / 2));
            if let Some(mut input) = app.world.get_resource_mut::<Input>() {
                input.release_button(MouseButton::Left);
                if let Some(&at) = click {
                    input.set_cursor(Some(at));
                    input.press_button(MouseButton::Left);
                }
            }
            app.update();
            if let Some(mut input) = app.world.get_resource_mut::<Input>() {
                input.begin_frame(); // what follows belongs to the next frame, as in a window
            }
            if let Some(e) = app.world.get_resource::<RenderStats>().and_then(|s| s.last_error.clone()) {
                return Err(format!("rendering failed: {e}").into());
            }
            if app.exit_requested() {
                break;
            }
        }
        // Pipelined, the last frame (and its error) is collected here.
        finish_frames(&mut app.world);
        if let Some(e) = app.world.get_resource::<RenderStats>().and_then(|s| s.last_error.clone()) {
            return Err(format!("rendering failed: {e}").into());
        }
        app.exit_result()?;
        let size = app.world.get_resource::<RenderSettings>().map_or((0, 0), |s| s.size);
        let Some(mut renderer) = app.world.get_resource_mut::<GpuRenderer>() else {
            return Err("no renderer: add GpuPlugin".into());
        };
        if let Some(path) = &self.screenshot {
            let pixels = renderer.0.read_display()?;
            image::save_buffer(path, &pixels, size.0, size.1, image::ExtendedColorType::Rgba8)
                .map_err(|e| format!("writing {}: {e}", path.display()))?;
        }
        let errors = renderer.0.take_validation_errors();
        if let Some(first) = errors.first() {
            return Err(format!("{} Vulkan validation errors, first: {first}", errors.len()).into());
        }
        let c = app.world.resource::<RenderStats>().last;
        let particles = if c.particles.capacity > 0 { format!(", {} particles started", c.particles.spawned) } else { String::new() };
        println!("headless: {} frames, {} instances, {} lights, {} decals{particles}", self.frames, c.instances, c.lights, c.decals);
        Ok(())
    }
}

/// Runs in a window, or headless when the command line asks for it or there is no display.
#[derive(Clone, Debug)]
pub enum RunPlugin {
    /// In a window.
    Window(WindowPlugin),
    /// Offscreen.
    Headless(HeadlessPlugin),
}

impl RunPlugin {
    /// From the process's arguments: `--headless` (or no reachable display) runs headless, with
    /// `--frames N` (default 60), `--size WxH` and `--screenshot PATH`; otherwise a window titled
    /// `title`.
    pub fn from_args(title: &str) -> Self {
        Self::parse(title, std::env::args().skip(1), display_available())
    }

    fn parse(title: &str, args: impl Iterator<Item = String>, display: bool) -> Self {
        let args: Vec<String> = args.collect();
        let value = |flag: &str| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1));
        if display && !args.iter().any(|a| a == "--headless") {
            return RunPlugin::Window(WindowPlugin { title: title.into(), ..Default::default() });
        }
        RunPlugin::Headless(HeadlessPlugin {
            frames: value("--frames").and_then(|f| f.parse().ok()).unwrap_or(60),
            screenshot: value("--screenshot").map(PathBuf::from),
            size: value("--size").and_then(|s| s.split_once('x')).and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?))),
            clicks: args
                .windows(2)
                .filter(|w| w[0] == "--click")
                .filter_map(|w| w[1].split_once(',').and_then(|(x, y)| Some(glam::Vec2::new(x.parse().ok()?, y.parse().ok()?))))
                .collect(),
        })
    }

    /// Whether it runs headless.
    pub fn is_headless(&self) -> bool {
        matches!(self, RunPlugin::Headless(_))
    }
}

impl Plugin for RunPlugin {
    fn build(&self, app: &mut App) {
        match self {
            RunPlugin::Window(w) => w.build(app),
            RunPlugin::Headless(h) => h.build(app),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str], display: bool) -> RunPlugin {
        RunPlugin::parse("t", args.iter().map(|s| s.to_string()), display)
    }

    #[test]
    fn the_command_line_chooses_window_or_headless() {
        assert!(matches!(parse(&[], true), RunPlugin::Window(w) if w.title == "t"));
        assert!(parse(&["--headless"], true).is_headless());
        assert!(parse(&[], false).is_headless(), "no display: headless");
        let args = ["--headless", "--frames", "7", "--screenshot", "a.png", "--size", "64x48", "--click", "3,4", "--click", "5,6"];
        let RunPlugin::Headless(h) = parse(&args, true) else { panic!() };
        assert_eq!((h.frames, h.screenshot, h.size), (7, Some(PathBuf::from("a.png")), Some((64, 48))));
        assert_eq!(h.clicks, [glam::Vec2::new(3.0, 4.0), glam::Vec2::new(5.0, 6.0)]);
        let RunPlugin::Headless(h) = parse(&["--frames", "x"], false) else { panic!() };
        assert_eq!(h.frames, 60, "a bad count keeps the default");
    }
}
