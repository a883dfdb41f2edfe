//! Windowed play: a winit window presenting through a Vulkan swapchain that survives resizes,
//! minimising and out-of-date swapchains, the egui overlay on top, mouse capture, and a clean
//! exit (the swapchain goes before the device, the device before the window).

use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context, Result, anyhow};
use plugins::{GpuRenderer, OverlayInput, RenderStats, WindowTarget};
use render::overlay::OverlayFrame;
use render::{DeviceSettings, RendererSettings};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{CursorGrabMode, Window, WindowId};

use engine::input::{Input, Key, MouseButton};

use crate::headless::{HeadlessOptions, build_app_with};
use crate::overlay_ui::OverlayUi;

/// How to run the windowed sandbox.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// Scene and rendering choices (frames = 0 runs until the window closes).
    pub base: HeadlessOptions,
    /// Exit after this many frames (for tests); `None` runs until closed.
    pub exit_after: Option<u32>,
    /// Resize the window to this size halfway through `exit_after` (for tests).
    pub resize_to: Option<(u32, u32)>,
}

/// Whether a display server looks reachable (X11 or Wayland).
pub fn display_available() -> bool {
    std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) || std::env::var_os("WAYLAND_DISPLAY").is_some_and(|d| !d.is_empty())
}

/// Opens the window and plays until it closes (or `exit_after` frames).
pub fn run_windowed(opts: WindowOptions) -> Result<()> {
    let event_loop = EventLoop::new().context("cannot open the display")?;
    let mut game = WindowedGame { opts, running: None, result: Ok(()), frames: 0 };
    let ran = event_loop.run_app(&mut game).context("the event loop failed");
    game.shut_down(); // in case the loop ended without `exiting`
    ran?;
    game.result
}

struct Running {
    // Field order is drop order: the app (renderer, device) before the window.
    app: engine::app::App,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    ui: OverlayUi,
    last_frame: Instant,
    cursor_grabbed: bool,
    window: Arc<Window>,
}

struct WindowedGame {
    opts: WindowOptions,
    running: Option<Running>,
    result: Result<()>,
    frames: u32,
}

impl WindowedGame {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running> {
        let (w, h) = self.opts.base.size;
        let attributes = Window::default_attributes().with_title("ecs-decals sandbox").with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).context("creating the window")?);
        let display = window.display_handle().map_err(|e| anyhow!("display handle: {e}"))?.as_raw();
        let raw_window = window.window_handle().map_err(|e| anyhow!("window handle: {e}"))?.as_raw();
        let settings = RendererSettings {
            device: DeviceSettings {
                max_tier: self.opts.base.max_tier,
                surface_extensions: render::window::required_extensions(display)?,
                ..Default::default()
            },
            ..Default::default()
        };
        let size = window.inner_size();
        let mut app = build_app_with(&self.opts.base, &settings)?;
        app.add_plugins(crate::game::GamePlugin);
        let camera = crate::game::find_camera(&mut app.world).context("the scene has no camera to play with")?;
        crate::game::setup_game(&mut app.world, camera)?;
        let renderer = &app.world.resource::<GpuRenderer>().0;
        let surface = renderer.create_window_surface(display, raw_window, size.width, size.height)?;
        app.insert_resource(WindowTarget(surface));
        app.insert_resource(OverlayInput::default());
        let egui_ctx = egui::Context::default();
        let egui_state =
            egui_winit::State::new(egui_ctx.clone(), egui::ViewportId::ROOT, &window, Some(window.scale_factor() as f32), None, None);
        Ok(Running { app, egui_ctx, egui_state, ui: OverlayUi::default(), last_frame: Instant::now(), cursor_grabbed: false, window })
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let Some(r) = self.running.as_mut() else { return };
        let now = Instant::now();
        let frame_ms = now.duration_since(r.last_frame).as_secs_f32() * 1e3;
        r.last_frame = now;
        r.ui.observe(&mut r.app.world, frame_ms);

        let input = r.egui_state.take_egui_input(&r.window);
        let (ui, world) = (&mut r.ui, &mut r.app.world);
        let output = r.egui_ctx.run_ui(input, |root| ui.show(&root.ctx().clone(), world));
        r.egui_state.handle_platform_output(&r.window, output.platform_output);
        let primitives = r.egui_ctx.tessellate(output.shapes, output.pixels_per_point);
        r.app.world.resource_mut::<OverlayInput>().0 =
            Some(OverlayFrame { primitives, textures_delta: output.textures_delta, pixels_per_point: output.pixels_per_point });

        r.app.update();
        // Events that arrive from now on belong to the next frame (engine::input's contract).
        if let Some(mut input) = r.app.world.get_resource_mut::<Input>() {
            input.begin_frame();
        }
        if let Some(e) = r.app.world.resource::<RenderStats>().last_error.clone() {
            self.result = Err(anyhow!("rendering failed: {e}"));
            event_loop.exit();
            return;
        }
        self.frames += 1;
        if let (Some(limit), Some((w, h))) = (self.opts.exit_after, self.opts.resize_to)
            && self.frames == limit / 2
        {
            let _ = r.window.request_inner_size(winit::dpi::PhysicalSize::new(w, h));
        }
        if self.opts.exit_after.is_some_and(|n| self.frames >= n) {
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
        if let Some(WindowTarget(surface)) = r.app.world.remove_resource::<WindowTarget>() {
            r.app.world.resource::<GpuRenderer>().0.destroy_window_surface(surface);
        }
        let errors = r.app.world.resource::<GpuRenderer>().0.take_validation_errors();
        if !errors.is_empty() && self.result.is_ok() {
            self.result = Err(anyhow!("{} Vulkan validation errors, first: {}", errors.len(), errors[0]));
        }
        drop(r);
    }
}

impl ApplicationHandler for WindowedGame {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
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
        let consumed = r.egui_state.on_window_event(&r.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(mut target) = r.app.world.get_resource_mut::<WindowTarget>() {
                    target.0.resize(size.width, size.height);
                }
                // The offscreen targets and the camera's aspect follow the window (not while
                // minimised, when there is nothing to draw).
                if size.width > 0 && size.height > 0 {
                    if let Err(e) = r.app.world.resource_mut::<GpuRenderer>().0.resize(size.width, size.height) {
                        self.result = Err(anyhow!("resizing the render targets: {e}"));
                        event_loop.exit();
                        return;
                    }
                    r.app.world.resource_mut::<plugins::RenderSettings>().size = (size.width, size.height);
                }
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            WindowEvent::KeyboardInput { event, .. } => {
                let pressed = event.state == ElementState::Pressed;
                if pressed && !event.repeat {
                    match event.physical_key {
                        PhysicalKey::Code(KeyCode::F1) => r.ui.visible = !r.ui.visible,
                        PhysicalKey::Code(KeyCode::Escape) if r.cursor_grabbed => Self::set_cursor_grab(r, false),
                        PhysicalKey::Code(KeyCode::Escape) => event_loop.exit(),
                        _ => {}
                    }
                }
                // Keys go to the game unless egui is typing into a widget.
                if let (PhysicalKey::Code(code), false) = (event.physical_key, consumed && pressed)
                    && let (Some(key), Some(mut input)) = (game_key(code), r.app.world.get_resource_mut::<Input>())
                {
                    if pressed { input.press(key) } else { input.release(key) }
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let pressed = state == ElementState::Pressed;
                if pressed && !consumed && !r.cursor_grabbed {
                    // The first click captures the mouse for mouse look; it does not shoot.
                    Self::set_cursor_grab(r, true);
                } else if r.cursor_grabbed || !pressed {
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

/// The game's key for a physical key, if the game uses it.
fn game_key(code: KeyCode) -> Option<Key> {
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
        KeyCode::Digit0 => Key::Digit0,
        KeyCode::Digit1 => Key::Digit1,
        KeyCode::Digit2 => Key::Digit2,
        KeyCode::Digit3 => Key::Digit3,
        KeyCode::Digit4 => Key::Digit4,
        KeyCode::Digit5 => Key::Digit5,
        KeyCode::Digit6 => Key::Digit6,
        KeyCode::Digit7 => Key::Digit7,
        KeyCode::Digit8 => Key::Digit8,
        KeyCode::Digit9 => Key::Digit9,
        _ => return None,
    })
}
