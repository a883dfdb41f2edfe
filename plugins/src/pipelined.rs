//! Pipelined rendering: a frame's upload, recording and submission run on a render thread of
//! their own while the main thread simulates the next frame ([`crate::RenderSettings::pipelined`]).
//!
//! **Why.** Without it, one update does everything in turn: animation, transform propagation,
//! skin matrices, extraction, then the renderer's upload, recording and submission, so the CPU
//! frame is their sum. At 10,000 animated foxes the renderer's share is about a quarter of that
//! frame, and the simulation before it waits for nothing the renderer does. With pipelining the
//! renderer takes the mirror extraction just wrote to its thread and draws frame N there, while
//! the main thread animates and propagates frame N + 1; the next extraction takes the mirror
//! back first. The main thread's frame is then the simulation and the extraction, and the
//! render thread's is the recording: the frame takes the longer of the two, not their sum. This
//! is the design of Bevy's `PipelinedRenderingPlugin` (extraction is the one sync point); the
//! difference is that ours moves the renderer and the mirror themselves between the threads
//! (by value, through one-slot channels, so a steady frame allocates nothing) instead of
//! keeping a second world.
//!
//! **What it changes for a game.** While a frame is in flight, [`GpuRenderer`],
//! [`RenderMirror`] and [`WindowTarget`] are not in the world: a system in `Update` that wants
//! them sees none (systems of the render schedule run after they are back). Code outside the
//! schedule that reads the renderer (a screenshot, validation errors, a read-back) calls
//! [`collect_frame`] first; [`crate::finish_frames`] does. A frame's statistics and counters
//! ([`RenderStats`]) arrive one update later than without pipelining, and errors are reported
//! by the next update (or by [`crate::finish_frames`] after the last). The frames drawn are the same: extraction sees the same world, and the
//! renderer the same mirror, in the same order.

use std::sync::Mutex;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;
use std::time::Instant;

use bevy_ecs::prelude::*;
use render::overlay::OverlayFrame;
use render::window::WindowSurface;
use render::{FrameReport, FrameSettings, RenderError, Renderer, SceneMirror};

use crate::{FrameContext, GpuRenderer, OverlayInput, RenderMirror, RenderStats, WindowTarget};

/// What the render thread draws a frame with (everything it needs, moved to it).
struct Job {
    window: Option<WindowSurface>,
    renderer: Renderer,
    mirror: SceneMirror,
    overlay: Option<OverlayFrame>,
    settings: FrameSettings,
}

/// What the render thread gives back: the same things, and what drawing returned.
struct Done {
    renderer: Renderer,
    mirror: SceneMirror,
    window: Option<WindowSurface>,
    result: Result<Option<FrameReport>, RenderError>,
}

/// The render thread and the frame it is drawing (a resource while pipelining was ever on).
#[derive(Resource)]
pub(crate) struct RenderThread {
    jobs: Option<SyncSender<Job>>,
    done: Mutex<Receiver<Done>>,
    /// What the main thread knew of the frame in flight, for its statistics.
    in_flight: Option<FrameContext>,
    thread: Option<JoinHandle<()>>,
}

impl RenderThread {
    fn start() -> std::io::Result<Self> {
        let (jobs, inbox) = sync_channel::<Job>(1);
        let (outbox, done) = sync_channel::<Done>(1);
        let thread = std::thread::Builder::new().name("render".into()).spawn(move || {
            // Ends when the sender is dropped (the resource with it).
            while let Ok(mut job) = inbox.recv() {
                let result = match job.window.as_mut() {
                    Some(window) => job.renderer.render_to_window(&mut job.mirror, &job.settings, window, job.overlay.as_mut()),
                    None => job.renderer.render(&mut job.mirror, &job.settings).map(Some),
                };
                let done = Done { renderer: job.renderer, mirror: job.mirror, window: job.window, result };
                if outbox.send(done).is_err() {
                    break;
                }
            }
        })?;
        Ok(Self { jobs: Some(jobs), done: Mutex::new(done), in_flight: None, thread: Some(thread) })
    }

    /// Waits for the frame in flight, if any, and returns it with its context (`Err` when the
    /// thread died drawing it, taking the renderer with it).
    fn receive(&mut self) -> Option<Result<(Done, FrameContext), ()>> {
        let context = self.in_flight.take()?;
        let done = self.done.get_mut().unwrap_or_else(|e| e.into_inner()).recv();
        Some(done.map(|done| (done, context)).map_err(drop))
    }
}

impl Drop for RenderThread {
    fn drop(&mut self) {
        // A frame still in flight takes its renderer down here (its drop waits for the GPU).
        drop(self.receive());
        drop(self.jobs.take());
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Takes the frame the render thread is drawing back into the world (waiting for it): puts
/// [`GpuRenderer`], [`RenderMirror`] and [`WindowTarget`] back and files the frame's report in
/// [`RenderStats`]. Does nothing when no frame is in flight. Call it before reading the renderer
/// outside the render schedule while [`crate::RenderSettings::pipelined`] is on.
pub fn collect_frame(world: &mut World) {
    collect(world);
}

/// [`collect_frame`] as the render schedule's first system: what the main thread waited for the
/// render thread's wait for the GPU is left out of this update's CPU frame.
pub(crate) fn collect_in_update(world: &mut World) {
    let gpu_wait_ms = collect(world);
    world.resource_mut::<RenderStats>().main_gpu_wait_ms = gpu_wait_ms;
}

/// [`collect_frame`]; returns how long the main thread waited for the render thread's wait for
/// the GPU before recording (milliseconds; 0 when nothing was in flight).
fn collect(world: &mut World) -> f32 {
    let Some(mut thread) = world.get_resource_mut::<RenderThread>() else { return 0.0 };
    let waited = Instant::now();
    let Some(received) = thread.receive() else { return 0.0 };
    let Ok((done, context)) = received else {
        // The renderer went down with the thread: end the app, with a fresh mirror so that
        // extraction still has one until it exits.
        let message = "the render thread stopped while drawing a frame".to_string();
        tracing::error!("{message}");
        crate::reset_mirror(world);
        let mut stats = world.resource_mut::<RenderStats>();
        stats.last_error = Some(message.clone());
        stats.failed = true;
        world.insert_resource(engine::app::AppExit::Error(message));
        return 0.0;
    };
    let waited_ms = waited.elapsed().as_secs_f32() * 1e3;
    world.insert_resource(GpuRenderer(done.renderer));
    world.insert_resource(RenderMirror(done.mirror));
    if let Some(window) = done.window {
        world.insert_resource(WindowTarget(window));
    }
    // The render thread's wait for the GPU before recording is not CPU work: the main thread's
    // wait here, up to that long, is taken as having waited on it.
    let gpu_wait_ms = done.result.as_ref().ok().and_then(Option::as_ref).map_or(0.0, |r| waited_ms.min(r.wait_ms));
    if let Some(exit) = crate::file_report(&mut world.resource_mut::<RenderStats>(), done.result, context) {
        world.insert_resource(exit);
    }
    gpu_wait_ms
}

/// The render schedule's last system while pipelining: moves the renderer, the mirror and the
/// window target to the render thread with this frame's settings.
pub(crate) fn hand_off_frame(world: &mut World) {
    if !world.contains_resource::<RenderThread>() {
        match RenderThread::start() {
            Ok(thread) => world.insert_resource(thread),
            Err(e) => {
                let message = format!("could not start the render thread: {e}");
                tracing::error!("{message}");
                world.resource_mut::<RenderStats>().last_error = Some(message.clone());
                world.insert_resource(engine::app::AppExit::Error(message));
                return;
            }
        }
    }
    let Some(settings) = crate::prepare_frame(world) else { return };
    let context = crate::frame_context(world, true);
    let (Some(GpuRenderer(renderer)), Some(RenderMirror(mirror))) =
        (world.remove_resource::<GpuRenderer>(), world.remove_resource::<RenderMirror>())
    else {
        unreachable!("prepare_frame checked both");
    };
    let window = world.remove_resource::<WindowTarget>().map(|w| w.0);
    let overlay = world.get_resource_mut::<OverlayInput>().and_then(|mut o| o.0.take());
    let mut thread = world.resource_mut::<RenderThread>();
    thread.in_flight = Some(context);
    let job = Job { renderer, mirror, window, overlay, settings };
    if let Err(std::sync::mpsc::SendError(job)) = thread.jobs.as_ref().expect("running").send(job) {
        // The thread is gone (it panicked): draw nothing more, keep the world whole.
        thread.in_flight = None;
        world.insert_resource(GpuRenderer(job.renderer));
        world.insert_resource(RenderMirror(job.mirror));
        if let Some(window) = job.window {
            world.insert_resource(WindowTarget(window));
        }
        let message = "the render thread stopped".to_string();
        world.resource_mut::<RenderStats>().last_error = Some(message.clone());
        world.insert_resource(engine::app::AppExit::Error(message));
    }
}
