//! Shared helpers for the integration tests in `tests/tests/suite/` (run with
//! `cargo nextest run -p tests` or `cargo test -p tests`): apps with or without a GPU renderer at
//! a chosen size and tier, validation checks, image statistics and error measures, the shared
//! glTF models, and a way for a test to run in a process of its own.
//!
//! ```no_run
//! use engine::prelude::*;
//!
//! let mut app = tests::gpu_app(128, 96, plugins::RenderSettings::default());
//! app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.0, 3.0)));
//! app.update();
//! tests::assert_no_validation_errors(&mut app);
//! let hdr = tests::renderer(&mut app).read_hdr().unwrap();
//! assert_eq!(hdr.len(), 128 * 96);
//! ```

#![forbid(unsafe_code)]

pub mod gltf_files;

use std::path::PathBuf;

use engine::prelude::*;
use plugins::{GpuRenderer, RenderPlugin, RenderSettings};
use render::{Renderer, RendererSettings};

/// The third-party glTF models beside the project (`../shared/assets/gltf` from the workspace
/// root). CI always has them, so their absence fails the calling test instead of skipping it.
///
/// # Panics
///
/// When the directory does not exist, with a message naming the expected path.
pub fn shared_gltf_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/assets/gltf");
    assert!(
        dir.is_dir(),
        "the shared glTF models are missing at {}: they live beside the project in ../shared/assets/gltf \
         (CI always has them; tests that need them fail rather than skip without them)",
        dir.display()
    );
    dir
}

/// An app with the render plugin but no GPU: extraction runs, nothing is drawn.
pub fn ecs_app() -> App {
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_millis(16)));
    app.add_plugins(RenderPlugin::new(RenderSettings { size: (64, 64), ..Default::default() }));
    app
}

/// The opacity a decal's GPU record gives it at the mirror's scene clock (the camera record's
/// `time`), lifetime fade included, as `decals.glsl` evaluates it; `None` without a record.
pub fn decal_opacity_in_mirror(app: &App, decal: Entity) -> Option<f32> {
    let slot = app.world.resource::<plugins::MirrorSlots>().decal(decal)?;
    let mirror = &app.world.resource::<plugins::RenderMirror>().0;
    let record = mirror.decals.records.get(slot)?;
    let life = (mirror.camera().time * record.life_scale + record.life_offset).clamp(0.0, 1.0);
    Some(record.opacity * life)
}

/// An app that renders offscreen at `w`×`h` on the default device with validation on.
pub fn gpu_app(w: u32, h: u32, settings: RenderSettings) -> App {
    gpu_app_at(w, h, settings, render::Tier::RayQuery)
}

/// The renderer of a GPU app.
pub fn renderer(app: &mut App) -> &mut Renderer {
    &mut app.world.resource_mut::<GpuRenderer>().into_inner().0
}

/// Fails the test if the validation layer reported anything.
pub fn assert_no_validation_errors(app: &mut App) {
    let errors = renderer(app).take_validation_errors();
    assert!(errors.is_empty(), "{} validation errors:\n{}", errors.len(), errors.join("\n"));
}

/// Statistics over an RGBA8 image, for "non-degenerate image" checks.
#[derive(Debug, Clone, Copy)]
pub struct ImageStats {
    /// Fraction of pixels that differ from the clear colour by more than 2/255 in some channel.
    pub coverage: f64,
    /// Variance of luma (0..1 scale).
    pub luma_variance: f64,
    /// Mean luma (0..1).
    pub mean_luma: f64,
}

/// Computes [`ImageStats`]; `clear` is the background colour as the display shows it.
pub fn image_stats(rgba: &[u8], clear: [u8; 3]) -> ImageStats {
    let n = (rgba.len() / 4) as f64;
    let mut covered = 0usize;
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for px in rgba.chunks_exact(4) {
        if (0..3).any(|c| (px[c] as i32 - clear[c] as i32).abs() > 2) {
            covered += 1;
        }
        let y = (0.2126 * px[0] as f64 + 0.7152 * px[1] as f64 + 0.0722 * px[2] as f64) / 255.0;
        sum += y;
        sum2 += y * y;
    }
    let mean = sum / n;
    ImageStats { coverage: covered as f64 / n, luma_variance: sum2 / n - mean * mean, mean_luma: mean }
}

/// A camera looking straight down at the origin from `height`, and the matching pixel → ground
/// (y = 0) mapping, for image tests on a horizontal plane.
pub struct TopDownView {
    /// The camera's transform.
    pub transform: Transform,
    /// The camera.
    pub camera: Camera,
    /// Image size.
    pub size: (u32, u32),
}

impl TopDownView {
    /// A view from `height` above the origin; image up is world −Z.
    pub fn new(height: f32, size: (u32, u32)) -> Self {
        let transform = Transform::from_xyz(0.0, height, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
        Self { transform, camera: Camera { fov_y: 50f32.to_radians(), ..Default::default() }, size }
    }

    /// Spawns the camera.
    pub fn spawn(&self, world: &mut World) {
        world.spawn((self.camera, self.transform));
    }

    /// Where the centre of pixel (`px`, `py`) sees the plane y = `plane_y`.
    pub fn ground_point(&self, px: u32, py: u32, plane_y: f32) -> Option<Vec3> {
        let (w, h) = self.size;
        let view = self.transform.compute_matrix().inverse();
        let inv = (self.camera.projection(w as f32 / h as f32) * view).inverse();
        let ndc = Vec2::new((px as f32 + 0.5) / w as f32 * 2.0 - 1.0, 1.0 - (py as f32 + 0.5) / h as f32 * 2.0);
        let eye = self.transform.translation;
        let dir = (inv.project_point3(ndc.extend(0.5)) - eye).normalize();
        if dir.y.abs() < 1e-6 {
            return None;
        }
        let t = (plane_y - eye.y) / dir.y;
        (t > 0.0).then(|| eye + dir * t)
    }
}

impl TopDownView {
    /// The pixel whose centre sees the ground point nearest to `p`.
    pub fn pixel_of(&self, p: Vec3) -> (u32, u32) {
        let mut best = (0, 0, f32::INFINITY);
        for py in 0..self.size.1 {
            for px in 0..self.size.0 {
                if let Some(q) = self.ground_point(px, py, p.y) {
                    let d = q.distance(p);
                    if d < best.2 {
                        best = (px, py, d);
                    }
                }
            }
        }
        (best.0, best.1)
    }
}

/// Mean and 99th-percentile absolute difference over every channel of two RGBA images,
/// counting only pixels where `mask` is true.
pub fn error_stats(a: &[[f32; 4]], b: &[[f32; 4]], mask: impl Fn(usize) -> bool) -> (f32, f32) {
    let mut errors: Vec<f32> = Vec::with_capacity(a.len() * 3);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        if mask(i) {
            errors.extend((0..3).map(|c| (x[c] - y[c]).abs()));
        }
    }
    if errors.is_empty() {
        return (0.0, 0.0);
    }
    errors.sort_by(f32::total_cmp);
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    let p99 = errors[((errors.len() - 1) as f32 * 0.99) as usize];
    (mean, p99)
}

/// [`gpu_app`] on a device whose capability tier is capped at `tier`.
pub fn gpu_app_at(w: u32, h: u32, settings: RenderSettings, tier: render::Tier) -> App {
    let device = render::DeviceSettings { max_tier: tier, ..Default::default() };
    gpu_app_with(w, h, settings, &RendererSettings { device, shadow_maps: TEST_SHADOW_MAPS, ..Default::default() })
}

/// Shadow maps of 256² texels, directional ones over the 12 m the test scenes span: enough for
/// the small test images, and quick on lavapipe (the default is 1024² over 60 m).
pub const TEST_SHADOW_MAPS: render::ShadowMapBudget = render::ShadowMapBudget { tile: 256, tiles: 24, directional_distance: 12.0 };

/// [`gpu_app`] with a renderer created from `renderer_settings`.
///
/// Its scenes are lit by the flat ambient colour of their `RenderSettings`, with the clear
/// colour behind them, not by the plugin's default procedural sky, without bloom and without
/// ambient occlusion: they check lights, decals and shadows against exact expectations.
/// Environment, display and occlusion tests insert their own
/// [`engine::environment::Environment`] and turn bloom or occlusion back on.
pub fn gpu_app_with(w: u32, h: u32, settings: RenderSettings, renderer_settings: &RendererSettings) -> App {
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_millis(16)));
    app.add_plugins(RenderPlugin::new(RenderSettings {
        size: (w, h),
        bloom: render::BloomSettings::OFF,
        occlusion: render::OcclusionSettings::OFF,
        ..settings
    }));
    app.insert_resource(engine::environment::Environment { source: engine::environment::EnvironmentSource::None, ..Default::default() });
    let renderer = Renderer::new(renderer_settings, w, h).expect("a Vulkan device (run scripts/setup.sh)");
    assert!(renderer.validation_enabled(), "GPU tests need the validation layer");
    app.insert_resource(GpuRenderer(renderer));
    app
}

/// One warning captured by [`WarningLog`]: its message and its `key` field (the entity or asset
/// the warning names, as `Debug` prints it), if any.
#[derive(Clone, Debug, Default)]
pub struct Warning {
    /// The formatted message.
    pub message: String,
    /// The `key` field, `Debug`-formatted.
    pub key: Option<String>,
}

/// Captures the warnings an app logs while it is alive: a thread-local `tracing` subscriber, so
/// tests running in parallel do not see each other's warnings, with the app's schedules made
/// single-threaded so that its systems log on this thread.
pub struct WarningLog {
    warnings: std::sync::Arc<std::sync::Mutex<Vec<Warning>>>,
    _guard: tracing::subscriber::DefaultGuard,
}

struct CaptureLayer(std::sync::Arc<std::sync::Mutex<Vec<Warning>>>);

impl tracing::field::Visit for Warning {
    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        match field.name() {
            "message" => self.message = format!("{value:?}"),
            "key" => self.key = Some(format!("{value:?}")),
            name => self.message.push_str(&format!(" {name}={value:?}")),
        }
    }
}

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for CaptureLayer {
    fn on_event(&self, event: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
        if *event.metadata().level() == tracing::Level::WARN {
            let mut warning = Warning::default();
            event.record(&mut warning);
            self.0.lock().unwrap().push(warning);
        }
    }
}

impl WarningLog {
    /// Starts capturing the warnings of `app` (and of anything else on this thread).
    pub fn capture(app: &mut App) -> Self {
        use bevy_ecs::schedule::SingleThreadedExecutor;
        use engine::app::{PostUpdate, PreUpdate, Render, Startup, Update};
        app.schedule_mut(Startup).set_executor(SingleThreadedExecutor::new());
        app.schedule_mut(PreUpdate).set_executor(SingleThreadedExecutor::new());
        app.schedule_mut(Update).set_executor(SingleThreadedExecutor::new());
        app.schedule_mut(PostUpdate).set_executor(SingleThreadedExecutor::new());
        app.schedule_mut(Render).set_executor(SingleThreadedExecutor::new());
        Self::capture_thread()
    }

    /// Starts capturing the warnings logged on this thread (a loader's, without an app).
    pub fn capture_thread() -> Self {
        use tracing_subscriber::layer::SubscriberExt;
        let warnings = std::sync::Arc::default();
        let subscriber = tracing_subscriber::registry().with(CaptureLayer(std::sync::Arc::clone(&warnings)));
        Self { warnings, _guard: tracing::subscriber::set_default(subscriber) }
    }

    /// Every warning so far.
    pub fn warnings(&self) -> Vec<Warning> {
        self.warnings.lock().unwrap().clone()
    }

    /// The warnings whose `key` is `key` (compared as `Debug` prints it).
    pub fn about(&self, key: impl std::fmt::Debug) -> Vec<Warning> {
        let key = format!("{key:?}");
        self.warnings().into_iter().filter(|w| w.key.as_deref() == Some(key.as_str())).collect()
    }
}

/// A KTX2 container of one level (`faces` 6 for a cube map, 1 otherwise) holding `data` in
/// `format`, serialized with the `ktx2` crate's own header, level-index and data-format
/// descriptor writers, for tests of the environment's KTX2 loading.
pub fn ktx2_file(format: ktx2::Format, width: u32, height: u32, faces: u32, data: &[u8]) -> Vec<u8> {
    let (descriptor, type_size) = ktx2::dfd::Basic::from_format(format).expect("a format the DFD table knows");
    let block = ktx2::dfd::Block::Basic(descriptor).to_vec();
    let dfd: Vec<u8> = ((block.len() + 4) as u32).to_le_bytes().into_iter().chain(block).collect();
    let dfd_offset = ktx2::Header::LENGTH + ktx2::LevelIndex::LENGTH;
    let data_offset = (dfd_offset + dfd.len()).next_multiple_of(16);
    let header = ktx2::Header {
        format: Some(format),
        type_size,
        pixel_width: width,
        pixel_height: height,
        pixel_depth: 0,
        layer_count: 0,
        face_count: faces,
        level_count: 1,
        supercompression_scheme: None,
        index: ktx2::Index {
            dfd_byte_offset: dfd_offset as u32,
            dfd_byte_length: dfd.len() as u32,
            kvd_byte_offset: 0,
            kvd_byte_length: 0,
            sgd_byte_offset: 0,
            sgd_byte_length: 0,
        },
    };
    let level =
        ktx2::LevelIndex { byte_offset: data_offset as u64, byte_length: data.len() as u64, uncompressed_byte_length: data.len() as u64 };
    let mut file = header.as_bytes().to_vec();
    file.extend_from_slice(&level.as_bytes());
    file.extend_from_slice(&dfd);
    file.resize(data_offset, 0);
    file.extend_from_slice(data);
    file
}

/// The variable that tells a child process of the test binary which test it runs the body of.
const OWN_PROCESS: &str = "TESTS_OWN_PROCESS";

/// Runs a test's body in a process of its own, for a test that changes its whole process (its
/// environment, or a heap count that other tests' allocations would disturb): in the test
/// binary's first process it starts the binary again running only this test, with `env` added to
/// its environment, waits, fails if that child failed, and returns `false` (return at once); in
/// the child it returns `true` (run the body). `module` is the test's `module_path!()` and `name`
/// its function's name.
///
/// # Panics
///
/// When the child cannot be started or fails.
pub fn in_own_process(module: &str, name: &str, env: &[(&str, &str)]) -> bool {
    // libtest names a test by its path below the crate root.
    let path = match module.split_once("::") {
        Some((_, below)) => format!("{below}::{name}"),
        None => name.to_string(),
    };
    if std::env::var(OWN_PROCESS).as_deref() == Ok(path.as_str()) {
        return true;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let child = std::process::Command::new(exe)
        .args([path.as_str(), "--exact", "--nocapture", "--test-threads=1"])
        .env(OWN_PROCESS, &path)
        .envs(env.iter().copied())
        .stderr(std::process::Stdio::inherit())
        .output()
        .expect("the test binary starts again");
    let stdout = String::from_utf8_lossy(&child.stdout);
    print!("{stdout}");
    assert!(child.status.success(), "{path}, run in a process of its own, failed: {}", child.status);
    // A name that matched no test would pass having run nothing.
    assert!(stdout.contains("test result: ok. 1 passed"), "{path}: the child process ran no test of that name");
    false
}
