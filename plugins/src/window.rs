//! A window for the app: [`WindowPlugin`] makes `app.run()` open a winit window and own its event
//! loop. The runner creates the renderer for the window (the instance extensions its surface
//! needs), presents through a Vulkan swapchain that survives resizes, minimising and out-of-date
//! swapchains, feeds keys, mouse buttons, cursor and mouse motion into [`engine::input::Input`],
//! draws the [`crate::overlay`] when its plugin is added, and exits cleanly: the swapchain goes
//! before the device, the device before the window. The title shows the pipeline, the capability
//! tier and the frame time; F12 writes the next frame (without the overlay) to
//! `screenshot-<frame>.png` in the working directory. A system ends the run by inserting
//! [`engine::app::AppExit`]; closing the window (or Escape, unless the cursor is grabbed) ends it too.
//!
//! ```no_run
//! use engine::prelude::*;
//! use plugins::window::WindowPlugin;
//! use plugins::{GpuPlugin, RenderPlugin, RenderSettings};
//!
//! let mut app = App::new();
//! app.add_plugins(RenderPlugin::new(RenderSettings::default()));
//! app.add_plugins(GpuPlugin::default());
//! app.add_plugins(WindowPlugin { title: "my game".into(), ..Default::default() });
//! // … spawn a camera, lights, meshes; add systems …
//! app.run().expect("the game ran");
//! ```

use std::sync::Arc;
use std::time::Instant;

use bevy_ecs::prelude::*;
use engine::app::{App, BoxError, Plugin, RunResult};
use engine::input::{Input, Key, MouseButton};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{CursorGrabMode, Window, WindowId};

use crate::overlay::DebugOverlay;
use crate::{GpuRenderer, OverlayInput, RenderSettings, RenderStats, RendererFromWindow, WindowTarget, start_renderer};

/// Opens a window and runs the app in it (`app.run()`).
#[derive(Resource, Clone, Debug)]
pub struct WindowPlugin {
    /// The window's title.
    pub title: String,
    /// The window's inner size in pixels; `None` takes [`RenderSettings::size`].
    pub size: Option<(u32, u32)>,
    /// A click in the window grabs the cursor (hidden, locked: mouse look), Escape frees it.
    pub grab_cursor_on_click: bool,
    /// Exit after this many frames (demos and tests); `None` runs until closed.
    pub exit_after: Option<u32>,
    /// Ask for this inner size halfway through `exit_after` (tests of resizing).
    pub resize_to: Option<(u32, u32)>,
}

impl Default for WindowPlugin {
    fn default() -> Self {
        Self { title: "ecs-decals".into(), size: None, grab_cursor_on_click: false, exit_after: None, resize_to: None }
    }
}

impl Plugin for WindowPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.clone());
        app.insert_resource(RendererFromWindow);
        app.set_runner(run_window);
    }
}

/// Whether a display server looks reachable (X11 or Wayland): without one, a game may run
/// headless instead of adding [`WindowPlugin`].
pub fn display_available() -> bool {
    std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) || std::env::var_os("WAYLAND_DISPLAY").is_some_and(|d| !d.is_empty())
}

/// The runner [`WindowPlugin`] installs: opens the window, plays until it closes, an
/// [`engine::app::AppExit`] or `exit_after` frames, and returns the first error (the display, the renderer,
/// a frame, or Vulkan validation errors when validation is on).
pub fn run_window(app: App) -> RunResult {
    let config = app.world.get_resource::<WindowPlugin>().cloned().unwrap_or_default();
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open the display: {e}"))?;
    let mut runner = WindowRunner { config, pending: Some(app), running: None, result: Ok(()), frames: 0 };
    let ran = event_loop.run_app(&mut runner);
    runner.shut_down(); // in case the loop ended without `exiting`
    ran.map_err(|e| format!("the event loop failed: {e}"))?;
    runner.result
}

struct Running {
    // Field order is drop order: the app (renderer, device) before the window.
    app: App,
    egui: Option<(egui::Context, egui_winit::State)>,
    last_frame: Instant,
    last_title: Instant,
    cursor_grabbed: bool,
    screenshot_requested: bool,
    window: Arc<Window>,
    /// The renderer's tier, for the title (the renderer may be on the render thread).
    tier: &'static str,
}

struct WindowRunner {
    config: WindowPlugin,
    pending: Option<App>,
    running: Option<Running>,
    result: RunResult,
    frames: u32,
}

impl WindowRunner {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, BoxError> {
        let mut app = self.pending.take().ok_or("the window runner started twice")?;
        let (w, h) = self.config.size.unwrap_or_else(|| app.world.get_resource::<RenderSettings>().map_or((1280, 720), |s| s.size));
        let attributes =
            Window::default_attributes().with_title(self.config.title.clone()).with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| format!("creating the window: {e}"))?);
        let display = window.display_handle().map_err(|e| format!("display handle: {e}"))?.as_raw();
        let raw_window = window.window_handle().map_err(|e| format!("window handle: {e}"))?.as_raw();
        let size = window.inner_size();
        if let Some(mut settings) = app.world.get_resource_mut::<RenderSettings>() {
            settings.size = (size.width.max(1), size.height.max(1));
        }
        let extensions = render::window::required_extensions(display)?;
        start_renderer(&mut app.world, extensions).map_err(|e| format!("could not start the renderer: {e}"))?;
        let renderer = &app.world.resource::<GpuRenderer>().0;
        let tier = renderer.tier().name();
        let surface = renderer.create_window_surface(display, raw_window, size.width, size.height)?;
        app.insert_resource(WindowTarget(surface));
        app.insert_resource(OverlayInput::default());
        let egui = app.world.contains_resource::<DebugOverlay>().then(|| {
            let ctx = egui::Context::default();
            let state =
                egui_winit::State::new(ctx.clone(), egui::ViewportId::ROOT, &window, Some(window.scale_factor() as f32), None, None);
            (ctx, state)
        });
        let now = Instant::now();
        Ok(Running { app, egui, last_frame: now, last_title: now, cursor_grabbed: false, screenshot_requested: false, window, tier })
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let Some(r) = self.running.as_mut() else { return };
        let now = Instant::now();
        let frame_ms = now.duration_since(r.last_frame).as_secs_f32() * 1e3;
        r.last_frame = now;
        // A screenshot frame is drawn offscreen (without the window target, so without the
        // overlay, whose textures only the window's pass would apply), then read back.
        let screenshot = std::mem::take(&mut r.screenshot_requested);
        if let (Some((ctx, state)), false) = (&mut r.egui, screenshot) {
            let input = state.take_egui_input(&r.window);
            let output = r.app.world.resource_scope(|world, mut overlay: Mut<DebugOverlay>| {
                overlay.observe(world, frame_ms);
                ctx.run_ui(input, |root| overlay.show(&root.ctx().clone(), world))
            });
            state.handle_platform_output(&r.window, output.platform_output);
            let primitives = ctx.tessellate(output.shapes, output.pixels_per_point);
            r.app.world.resource_mut::<OverlayInput>().0 = Some(render::overlay::OverlayFrame {
                primitives,
                textures_delta: output.textures_delta,
                pixels_per_point: output.pixels_per_point,
            });
        }

        // Pipelined, the window target is with the frame in flight: take that frame back first.
        let window_target = if screenshot {
            crate::pipelined::collect_frame(&mut r.app.world);
            r.app.world.remove_resource::<WindowTarget>()
        } else {
            None
        };
        r.app.update();
        if let Some(target) = window_target {
            match save_screenshot(&mut r.app) {
                Ok(path) => tracing::info!("screenshot: {}", path.display()),
                Err(e) => tracing::warn!("no screenshot: {e}"),
            }
            r.app.world.insert_resource(target);
        }
        if now.duration_since(r.last_title).as_secs_f32() > 0.5 {
            r.last_title = now;
            let settings = r.app.world.get_resource::<RenderSettings>().map(|s| s.pipeline.name()).unwrap_or("?");
            let tier = r.tier;
            r.window.set_title(&format!("{} | {settings} | {tier} | {frame_ms:.1} ms", self.config.title));
        }
        // Events that arrive from now on belong to the next frame (engine::input's contract).
        if let Some(mut input) = r.app.world.get_resource_mut::<Input>() {
            input.begin_frame();
        }
        if let Some(e) = r.app.world.resource::<RenderStats>().last_error.clone() {
            self.result = Err(format!("rendering failed: {e}").into());
            event_loop.exit();
            return;
        }
        if r.app.exit_requested() {
            self.result = r.app.exit_result();
            event_loop.exit();
            return;
        }
        self.frames += 1;
        if let (Some(limit), Some((w, h))) = (self.config.exit_after, self.config.resize_to)
            && self.frames == limit / 2
        {
            let _ = r.window.request_inner_size(winit::dpi::PhysicalSize::new(w, h));
        }
        if self.config.exit_after.is_some_and(|n| self.frames >= n) {
            event_loop.exit();
        }
    }

    fn set_cursor_grab(r: &mut Running, grab: bool) {
        let mode = if grab { CursorGrabMode::Locked } else { CursorGrabMode::None };
        let ok = r.window.set_cursor_grab(mode).or_else(|_| if grab { r.window.set_cursor_grab(CursorGrabMode::Confined) } else { Ok(()) });
        if ok.is_ok() {
            r.window.set_cursor_visible(!grab);
            r.cursor_grabbed = grab;
        }
    }

    /// Tears down in the only safe order: swapchain, then renderer and device, then window.
    fn shut_down(&mut self) {
        let Some(mut r) = self.running.take() else { return };
        crate::pipelined::collect_frame(&mut r.app.world);
        if let Some(e) = r.app.world.resource::<RenderStats>().last_error.clone()
            && self.result.is_ok()
        {
            self.result = Err(format!("rendering failed: {e}").into());
        }
        // No renderer when it went down with the render thread (nothing left to destroy with).
        let target = r.app.world.remove_resource::<WindowTarget>();
        let Some(renderer) = r.app.world.get_resource::<GpuRenderer>() else { return };
        if let Some(WindowTarget(surface)) = target {
            renderer.0.destroy_window_surface(surface);
        }
        let errors = renderer.0.take_validation_errors();
        if !errors.is_empty() && self.result.is_ok() {
            self.result = Err(format!("{} Vulkan validation errors, first: {}", errors.len(), errors[0]).into());
        }
        drop(r);
    }
}

impl ApplicationHandler for WindowRunner {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() || self.pending.is_none() {
            return;
        }
        match self.start(event_loop) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.result = Err(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else { return };
        let consumed = match &mut r.egui {
            Some((_, state)) => state.on_window_event(&r.window, &event).consumed,
            None => false,
        };
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                crate::pipelined::collect_frame(&mut r.app.world);
                if let Some(mut target) = r.app.world.get_resource_mut::<WindowTarget>() {
                    target.0.resize(size.width, size.height);
                }
                // The offscreen targets and the camera's aspect follow the window (not while
                // minimised, when there is nothing to draw).
                if size.width > 0
                    && size.height > 0
                    && let Some(mut renderer) = r.app.world.get_resource_mut::<GpuRenderer>()
                {
                    if let Err(e) = renderer.0.resize(size.width, size.height) {
                        self.result = Err(format!("resizing the render targets: {e}").into());
                        event_loop.exit();
                        return;
                    }
                    r.app.world.resource_mut::<RenderSettings>().size = (size.width, size.height);
                }
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            WindowEvent::KeyboardInput { event, .. } => {
                let pressed = event.state == ElementState::Pressed;
                if pressed && !event.repeat {
                    match event.physical_key {
                        PhysicalKey::Code(KeyCode::F1) => {
                            if let Some(mut overlay) = r.app.world.get_resource_mut::<DebugOverlay>() {
                                overlay.visible = !overlay.visible;
                            }
                        }
                        PhysicalKey::Code(KeyCode::F12) => r.screenshot_requested = true,
                        PhysicalKey::Code(KeyCode::Escape) if r.cursor_grabbed => Self::set_cursor_grab(r, false),
                        PhysicalKey::Code(KeyCode::Escape) => event_loop.exit(),
                        _ => {}
                    }
                }
                // Keys go to the game unless egui is typing into a widget.
                if let (PhysicalKey::Code(code), false) = (event.physical_key, consumed && pressed)
                    && let (Some(key), Some(mut input)) = (engine_key(code), r.app.world.get_resource_mut::<Input>())
                {
                    if pressed { input.press(key) } else { input.release(key) }
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let pressed = state == ElementState::Pressed;
                if pressed && !consumed && !r.cursor_grabbed && self.config.grab_cursor_on_click {
                    // The first click captures the mouse for mouse look; it does not shoot.
                    Self::set_cursor_grab(r, true);
                } else if !consumed || !pressed {
                    let button = match button {
                        winit::event::MouseButton::Left => Some(MouseButton::Left),
                        winit::event::MouseButton::Right => Some(MouseButton::Right),
                        winit::event::MouseButton::Middle => Some(MouseButton::Middle),
                        _ => None,
                    };
                    if let (Some(button), Some(mut input)) = (button, r.app.world.get_resource_mut::<Input>()) {
                        if pressed { input.press_button(button) } else { input.release_button(button) }
                    }
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(mut input) = r.app.world.get_resource_mut::<Input>() {
                    input.set_cursor(Some(glam::Vec2::new(position.x as f32, position.y as f32)));
                }
            }
            WindowEvent::CursorLeft { .. } => {
                if let Some(mut input) = r.app.world.get_resource_mut::<Input>() {
                    input.set_cursor(None);
                }
            }
            WindowEvent::Focused(false) => {
                if let Some(mut input) = r.app.world.get_resource_mut::<Input>() {
                    input.release_all(); // no key stays stuck down while another window has focus
                }
                Self::set_cursor_grab(r, false);
            }
            _ => {}
        }
    }

    fn device_event(&mut self, _event_loop: &ActiveEventLoop, _device: winit::event::DeviceId, event: winit::event::DeviceEvent) {
        let Some(r) = self.running.as_mut() else { return };
        if let winit::event::DeviceEvent::MouseMotion { delta } = event
            && r.cursor_grabbed
            && let Some(mut input) = r.app.world.get_resource_mut::<Input>()
        {
            input.add_mouse_motion(glam::Vec2::new(delta.0 as f32, delta.1 as f32));
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(r) = &self.running {
            r.window.request_redraw();
        }
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        self.shut_down();
    }
}

/// Writes the frame just drawn offscreen to `screenshot-<frame>.png` in the working directory.
fn save_screenshot(app: &mut App) -> Result<std::path::PathBuf, BoxError> {
    crate::finish_frames(&mut app.world);
    let (w, h) = app.world.resource::<RenderSettings>().size;
    let frame = app.world.resource::<engine::time::Time>().frame();
    let pixels = app.world.resource_mut::<GpuRenderer>().0.read_display()?;
    let path = std::path::PathBuf::from(format!("screenshot-{frame}.png"));
    image::save_buffer(&path, &pixels, w, h, image::ExtendedColorType::Rgba8)?;
    Ok(path)
}

/// The engine's key for a physical key, if the engine has one.
fn engine_key(code: KeyCode) -> Option<Key> {
    Some(match code {
        KeyCode::KeyW => Key::W,
        KeyCode::KeyA => Key::A,
        KeyCode::KeyS => Key::S,
        KeyCode::KeyD => Key::D,
        KeyCode::KeyE => Key::E,
        KeyCode::KeyF => Key::F,
        KeyCode::KeyL => Key::L,
        KeyCode::Space => Key::Space,
        KeyCode::ShiftLeft | KeyCode::ShiftRight => Key::Shift,
        KeyCode::Escape => Key::Escape,
        KeyCode::Tab => Key::Tab,
        KeyCode::F1 => Key::F1,
        KeyCode::Digit0 | KeyCode::Numpad0 => Key::Digit0,
        KeyCode::Digit1 | KeyCode::Numpad1 => Key::Digit1,
        KeyCode::Digit2 | KeyCode::Numpad2 => Key::Digit2,
        KeyCode::Digit3 | KeyCode::Numpad3 => Key::Digit3,
        KeyCode::Digit4 | KeyCode::Numpad4 => Key::Digit4,
        KeyCode::Digit5 | KeyCode::Numpad5 => Key::Digit5,
        KeyCode::Digit6 | KeyCode::Numpad6 => Key::Digit6,
        KeyCode::Digit7 | KeyCode::Numpad7 => Key::Digit7,
        KeyCode::Digit8 | KeyCode::Numpad8 => Key::Digit8,
        KeyCode::Digit9 | KeyCode::Numpad9 => Key::Digit9,
        _ => return None,
    })
}
