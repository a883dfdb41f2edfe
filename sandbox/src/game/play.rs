//! Headless scripted play: the headless renderer of [`crate::headless`] with the game on top,
//! driven by a [`Script`] instead of a keyboard, writing the same screenshot and statistics.
//!
//! [`run_scripted`] builds the app of a headless run ([`crate::headless::build_app`]: scene,
//! scattered decals, renderer, fixed 1/60 s frame time), adds [`GamePlugin`], makes the scene's
//! first active camera the player ([`setup_game`]) and plays the script to its end, then
//! `HeadlessOptions::frames` more frames (so the last shot's decal is on screen, and effects
//! settle). Every `--stats` line gets a `game` object with the game's state after that frame:
//! the [`GameStats`] counters, `live_decals`, `live_lights`, the player's `eye` position and
//! the script line that played in that frame (`script_line`, null once the script is over).

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use bevy_ecs::query::With;
use bevy_ecs::world::World;
use engine::app::App;
use engine::time::Time;
use engine::transform::Transform;
use plugins::{GpuRenderer, RenderStats, finish_frames};
use serde_json::{Value, json};

use super::decal_cap::{GameDecal, GameLight, SpawnOrder};
use super::player::Player;
use super::script::{Script, ScriptPlayer};
use super::{GamePlugin, GameStats, find_camera, setup_game};
use crate::headless::{HeadlessOptions, build_app};

/// What a scripted run produced.
pub struct GameRunSummary {
    /// The app after the run (for tests to inspect).
    pub app: App,
    /// The last frame, RGBA8 sRGB.
    pub pixels: Vec<u8>,
    /// The statistics of every frame, oldest first, each with its `game` object.
    pub frames: Vec<Value>,
    /// Validation errors reported during the run.
    pub validation_errors: Vec<String>,
    /// The game's counters at the end.
    pub game: GameStats,
}

/// Builds the headless app of `opts` with the game set up and `script` loaded, ready to play.
/// `--compare` runs are refused (a script plays one pipeline).
pub fn build_game_app(opts: &HeadlessOptions, script: Script) -> Result<App> {
    if opts.compare {
        bail!("a scripted run plays one pipeline; it does not combine with --compare");
    }
    let mut app = build_app(opts)?;
    app.add_plugins(GamePlugin);
    let camera = find_camera(&mut app.world).context("the scene has no active camera to play with")?;
    setup_game(&mut app.world, camera)?;
    app.insert_resource(ScriptPlayer::new(script));
    Ok(app)
}

/// Plays `script` headless (see the module docs), writing `opts.screenshot` and `opts.stats`
/// when set.
pub fn run_scripted(opts: &HeadlessOptions, script: Script) -> Result<GameRunSummary> {
    let mut app = build_game_app(opts, script)?;
    let dt = app.world.resource::<Time>().fixed_step().map_or(0.0, |step| step.as_secs_f32());
    let script_frames = app.world.resource::<ScriptPlayer>().script().frames_at(dt).context("scripted runs need a fixed frame time")?;
    let total = script_frames + u64::from(opts.frames);
    let mut snapshots = Vec::with_capacity(total as usize);
    let mut frames = Vec::with_capacity(total as usize);
    let renderer = &app.world.resource::<GpuRenderer>().0;
    let device = (renderer.tier().name(), renderer.device_name().to_string());
    for _ in 0..total {
        app.update();
        if let Some(error) = app.world.resource::<RenderStats>().last_error.clone() {
            bail!("rendering failed: {error}");
        }
        snapshots.push(game_snapshot(&mut app.world));
        drain_stats(&mut app, &device, &snapshots, &mut frames);
    }
    finish_frames(&mut app.world);
    // Pipelined, the last frame's error arrives with it.
    if let Some(error) = app.world.resource::<RenderStats>().last_error.clone() {
        bail!("rendering failed: {error}");
    }
    drain_stats(&mut app, &device, &snapshots, &mut frames);
    if let Some(path) = &opts.stats {
        let mut file = std::io::BufWriter::new(create(path)?);
        for frame in &frames {
            writeln!(file, "{frame}")?;
        }
        file.flush().with_context(|| format!("writing {}", path.display()))?;
    }
    let renderer = &mut app.world.resource_mut::<GpuRenderer>().0;
    let pixels = renderer.read_display().context("reading back the frame")?;
    let validation_errors = renderer.take_validation_errors();
    if let Some(path) = &opts.screenshot {
        let (w, h) = opts.size;
        create_parent(path)?;
        image::save_buffer(path, &pixels, w, h, image::ExtendedColorType::Rgba8).with_context(|| format!("writing {}", path.display()))?;
    }
    let game = *app.world.resource::<GameStats>();
    Ok(GameRunSummary { app, pixels, frames, validation_errors, game })
}

/// The game's state after a frame, as the `game` object of its statistics.
fn game_snapshot(world: &mut World) -> Value {
    let eye = world.query_filtered::<&Transform, With<Player>>().iter(world).next().map(|t| t.translation.to_array());
    let script_line = world.get_resource::<ScriptPlayer>().and_then(ScriptPlayer::played_line);
    let live_decals = world.resource::<SpawnOrder<GameDecal>>().len();
    let live_lights = world.resource::<SpawnOrder<GameLight>>().len();
    let mut game = serde_json::to_value(*world.resource::<GameStats>()).unwrap_or_else(|_| json!({}));
    if let Value::Object(map) = &mut game {
        map.insert("live_decals".into(), json!(live_decals));
        map.insert("live_lights".into(), json!(live_lights));
        map.insert("eye".into(), json!(eye));
        map.insert("script_line".into(), json!(script_line));
    }
    game
}

/// Moves finished frames' statistics into `out`, each with the game snapshot of its frame;
/// `(tier, device)` names the renderer's (which may be on the render thread).
fn drain_stats(app: &mut App, (tier, device): &(&str, String), snapshots: &[Value], out: &mut Vec<Value>) {
    let mut stats = app.world.resource_mut::<RenderStats>();
    while let Some(frame) = stats.completed.pop_front() {
        let mut value = crate::stats::frame_json(&frame, tier, device);
        if let (Value::Object(map), Some(game)) = (&mut value, snapshots.get(frame.frame as usize)) {
            map.insert("game".into(), game.clone());
        }
        out.push(value);
    }
}

/// Creates the folder `path` goes in, if missing.
fn create_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}

/// Creates `path` (and its folder).
fn create(path: &Path) -> Result<std::fs::File> {
    create_parent(path)?;
    std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))
}
