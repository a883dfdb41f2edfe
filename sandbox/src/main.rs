//! `sandbox`: the reference game. This build plays headless: it renders a scene offscreen and
//! writes a screenshot and per-frame statistics.

#![forbid(unsafe_code)]

use std::path::PathBuf;

use anyhow::{Result, bail};

/// Counts the engine's heap for the soak's memory check.
#[global_allocator]
static ALLOCATOR: cap::Cap<std::alloc::System> = cap::Cap::new(std::alloc::System, usize::MAX);
use clap::Parser;
use render::{DebugView, DecalMethod, PipelineKind, Tier};
use sandbox::game::play::run_scripted;
use sandbox::game::script::Script;
use sandbox::headless::{HeadlessOptions, SceneSource, run};

/// Command line. The flags are stable; later versions add flags, none change meaning.
#[derive(Parser, Debug)]
#[command(version, about = "The ecs-decals sandbox")]
struct Cli {
    /// Render offscreen (no window).
    #[arg(long)]
    headless: bool,
    /// Frames to render.
    #[arg(long, default_value_t = 120)]
    frames: u32,
    /// Render size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// `default` (the generated courtyard) or a .gltf/.glb path.
    #[arg(long, default_value = "default")]
    scene: String,
    /// The animated character that walks the courtyard (and fills `--bench-scene foxes`): a
    /// skinned .gltf/.glb, or `none`. Default: the shared Fox, when ../shared/assets has it.
    #[arg(long)]
    character: Option<String>,
    /// The clip `--bench-scene foxes` plays (Walk; PEERS.md's comparison uses Run).
    #[arg(long, default_value = "Walk")]
    character_clip: String,
    /// Write the last frame here as PNG.
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Write one JSON object per frame here.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Pipeline: forward, forward_plus, deferred or visbuffer.
    #[arg(long, default_value = "forward", value_parser = parse_pipeline)]
    pipeline: PipelineKind,
    /// Decal method: ray_query, ray_query_compute, ray_pipeline, clustered, deferred (deferred
    /// pipeline only) or off. One the device cannot run falls back to ray_query, else clustered.
    #[arg(long, default_value = "ray_query", value_parser = parse_decal_method)]
    decal_method: DecalMethod,
    /// Highest capability tier to use: ray_query, ray_tracing_pipeline or none.
    #[arg(long, default_value = "ray_query", value_parser = parse_tier)]
    tier: Tier,
    /// Scatter this many decals over the scene's surfaces (built-in textures).
    #[arg(long, default_value_t = 0)]
    decals: usize,
    /// Seed for --decals.
    #[arg(long, default_value_t = 1)]
    decal_seed: u64,
    /// What to show: lit, decal-heatmap, albedo, normal, roughness-metallic, light-heatmap,
    /// shadow-rays, depth-normals, reflections (the reflection rays' hit distance),
    /// ambient-occlusion, decal-floor (with --decal-method ray_pipeline, the ray-tracing-pipeline
    /// decal pass only counts the decals at each pixel: its floor, for benchmarks).
    #[arg(long, default_value = "lit", value_parser = parse_debug_view)]
    debug_view: DebugView,
    /// Draw every decal's box and AABB.
    #[arg(long)]
    decal_boxes: bool,
    /// Nudge this percentage of the decals every frame (for refit benchmarks).
    #[arg(long, default_value_t = 0.0)]
    move_decals: f32,
    /// Sway the camera sideways every frame (for benchmarks of a moving view).
    #[arg(long)]
    move_camera: bool,
    /// Every frame, despawn this many of the oldest decals and spawn as many new ones (copies of
    /// them, so the image stays the same): bullet holes coming and going, for CPU benchmarks.
    #[arg(long, default_value_t = 0)]
    churn_decals: usize,
    /// A benchmark scene instead of --scene: few-blended-decals, decals-and-lights, many-decals,
    /// ten-point-lights, many-lights, transparency, many-instances, behind-wall, foxes, crowd (foxes seen from eye height),
    /// particles (a fountain of --particles particles), corridor (a dark corridor lit by glowing
    /// decals and area lights).
    #[arg(long)]
    bench_scene: Option<String>,
    /// Run --frames frames with each pipeline and decal method in turn (with --stats, also a CSV
    /// and an SVG chart of each run's per-pass medians beside the stats file).
    #[arg(long)]
    compare: bool,
    /// Run --frames frames with each light-culling and shadow configuration of seed 001's
    /// Tables 5.1 and 5.2 in turn.
    #[arg(long)]
    compare_lights: bool,
    /// Run --frames frames with each light method (all, tiled, ray_query) in turn, in --pipeline
    /// with the other light settings as given.
    #[arg(long)]
    compare_light_methods: bool,
    /// Run `--frames` frames with each transparency configuration of seed 002's Tables 4.2,
    /// 4.3, 4.4 and 4.5 in turn (0–64 spot lights; interlaced deferred with and without
    /// refraction, with and without shadows against depth-peeled deferred, deferred with a
    /// forward transparency pass and the forward pipeline; coloured and opaque glass shadows,
    /// traced and mapped), meant for `--bench-scene transparency`.
    #[arg(long)]
    compare_transparency: bool,
    /// Light assignment: all (every pixel loops over every light), tiled (light culling) or
    /// ray_query (lights found by a zero-length ray through their boxes; deferred and visbuffer
    /// on devices with ray tracing, tiled elsewhere).
    #[arg(long, default_value = "tiled", value_parser = parse_light_method)]
    lights: render::LightMethod,
    /// Light tile size in pixels: 8, 16 or 32.
    #[arg(long, default_value_t = 16)]
    tile_size: u32,
    /// No ray-traced shadows.
    #[arg(long)]
    no_shadows: bool,
    /// Light culling without the tile AABB test.
    #[arg(long)]
    no_light_aabb: bool,
    /// Light culling without the tile depth mask (Harada's 2.5D culling: 32 depth slices a tile).
    #[arg(long)]
    no_light_depth_mask: bool,
    /// Trace shadow rays even towards lights the surface faces away from.
    #[arg(long)]
    no_shadow_ray_culling: bool,
    /// Shadow maps even on devices that trace shadow rays (devices without ray tracing always
    /// use them).
    #[arg(long)]
    shadow_maps: bool,
    /// Glass casts opaque shadows instead of coloured ones.
    #[arg(long)]
    opaque_glass_shadows: bool,
    /// Shadow maps: a tile's side in texels.
    #[arg(long, default_value_t = render::ShadowMapBudget::default().tile)]
    shadow_map_size: u32,
    /// Shadow maps: tiles in the atlas (a spot or directional light takes one, a point light
    /// six; lights past it are unshadowed).
    #[arg(long, default_value_t = render::ShadowMapBudget::default().tiles)]
    shadow_map_tiles: u32,
    /// Deferred lighting and visibility-buffer shading as full-screen fragment passes instead of
    /// compute.
    #[arg(long)]
    fragment_shading: bool,
    /// Forward and Forward+ apply clustered decals in their shading pass (no decal pass, no ids
    /// prepass); slower on the lent H100 (docs/experiments/decals-in-forward-shading.md)
    #[arg(long)]
    decals_in_forward_shading: bool,
    /// Blended (glass) surfaces: interlaced into the deferred G-buffer (seed 002; deferred
    /// only, other pipelines draw them forward), interlaced_pairs (the seed's composition),
    /// forward over the opaque image, or depth_peeling (deferred only: two G-buffers, the
    /// full-resolution reference).
    #[arg(long, default_value = "interlaced", value_parser = parse_transparency)]
    transparency: render::TransparencyMethod,
    /// Normals from depth for the shadow pass: naive or improved.
    #[arg(long, default_value = "improved", value_parser = parse_depth_normals)]
    depth_normals: render::DepthNormals,
    /// Traced shadows of the lights' lists (and of ray-query lights): exhaustive (a ray per
    /// light), stochastic (one ray a pixel to a sampled light) or auto (stochastic where a list
    /// holds more than 32 lights; ray-query lights: the first 32 a pixel finds get a ray each).
    #[arg(long, default_value = "auto", value_parser = parse_direct_light)]
    direct_light: render::DirectLight,
    /// Run --frames frames with each direct-light method (exhaustive, stochastic, auto), then
    /// exhaustive again, in --pipeline with the other settings as given.
    #[arg(long)]
    compare_direct_light: bool,
    /// Headless: play this script (see sandbox::game::script) with the game's systems.
    #[arg(long)]
    script: Option<PathBuf>,
    /// Windowed: close after this many frames (tests).
    #[arg(long)]
    exit_after: Option<u32>,
    /// Windowed: resize the window to WIDTHxHEIGHT halfway through --exit-after (tests).
    #[arg(long, value_parser = parse_size)]
    resize_to: Option<(u32, u32)>,
    /// Soak: --frames frames of random gameplay, switches, resizes and tier changes under
    /// validation (see sandbox::soak), split into --soak-cycles cycles; prints a JSON report and
    /// fails when the soak does. Uses --seed and --size (default 48x32 here).
    #[arg(long)]
    soak: bool,
    /// Soak: cycles, each on a random tier and ending with everything despawned.
    #[arg(long, default_value_t = 4)]
    soak_cycles: u32,
    /// Soak: without the validation layer (only to measure the layer's own cost).
    #[arg(long)]
    soak_without_validation: bool,
    /// Soak: the seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// GPU culling of instances: off, frustum, occlusion (frustum and two-phase
    /// hierarchical-Z).
    #[arg(long, default_value = "occlusion", value_parser = parse_culling)]
    culling: render::CullingMode,
    /// Levels of detail: the most pixels a coarser level's error may cover on screen for an
    /// instance to draw it (0: every instance in full).
    #[arg(long, default_value_t = render::lod::DEFAULT_LOD_PIXELS, value_parser = parse_lod_pixels)]
    lod_pixels: f32,
    /// Skinned characters shorter on screen than this many pixels have their ray-tracing
    /// structure refit every other frame instead of every frame (0: every frame).
    #[arg(long, default_value_t = render::settings::DEFAULT_REFIT_PIXELS, value_parser = parse_refit_pixels)]
    refit_pixels: f32,
    /// Skin every vertex of every character, not only those of the level of detail it will be
    /// drawn at (for comparison).
    #[arg(long)]
    full_skinning: bool,
    /// Run --frames frames with levels of detail off, on (at --lod-pixels), then off again.
    #[arg(long)]
    compare_lod: bool,
    /// Record every frame's command buffer, instead of submitting it again when a frame's
    /// commands are exactly those it holds (for comparison; --stats counters.commands_reused).
    #[arg(long)]
    record_every_frame: bool,
    /// Record and submit each frame on a render thread while the main thread simulates the
    /// next one (pipelined rendering: the CPU frame is the longer of the two, not their sum;
    /// statistics arrive a frame later).
    #[arg(long)]
    pipelined: bool,
    /// Animate characters small on screen (under 32 pixels of radius) or off it every second or
    /// fourth frame, staggered (engine::animation::AnimationBudget; --stats animation.sampled).
    #[arg(long)]
    animation_budget: bool,
    /// Pose the foxes and crowd scenes' characters through their bones' entities (animation,
    /// transform propagation, skin matrices: what a character carrying things needs) instead of
    /// as compact skeletons posed in one pass, their bones' entities left unplaced
    /// (engine::animation::CompactSkeleton and UnplacedBones; for comparison).
    #[arg(long)]
    bone_entities: bool,
    /// Wait for the GPU to finish each frame before the next update starts (headless, not with
    /// --pipelined). Where the GPU is emulated on the CPU's own cores (lavapipe), its work
    /// otherwise runs beside the next frame's update, and cpu_ms then measures the two sharing
    /// the cores.
    #[arg(long, conflicts_with = "pipelined")]
    gpu_idle_between_frames: bool,
    /// Anti-aliasing of the displayed image: none, fxaa (fast approximate, in compute before
    /// tone mapping), smaa (subpixel morphological, 1x, in compute), taa (temporal: jittered frames blended along motion vectors; none under a
    /// debug view), msaa2, msaa4, msaa8 (multisampling in forward and Forward+; taa in the
    /// deferred pipelines, and no more samples than the device offers). --stats reports the
    /// mode applied.
    #[arg(long, default_value = "taa", value_parser = parse_aa)]
    aa: render::AntiAliasing,
    /// Temporal anti-aliasing's sharpening, 0 to 1.
    #[arg(long, default_value_t = 0.25)]
    taa_sharpen: f32,
    /// Reflections of smooth surfaces: off, ray_traced (needs ray tracing; falls back to
    /// screen_space without, which --stats reports), screen_space.
    #[arg(long, default_value = "ray_traced", value_parser = parse_reflections)]
    reflections: render::ReflectionMode,
    /// Surfaces at least this rough reflect nothing.
    #[arg(long, default_value_t = render::ReflectionSettings::default().roughness_cutoff)]
    reflection_cutoff: f32,
    /// Trace one reflection ray per 2×2 pixels, upsampled by depth.
    #[arg(long)]
    half_res_reflections: bool,
    /// Reflections without the decals at their hit points (to measure what those cost).
    #[arg(long)]
    no_reflection_decals: bool,
    /// Run --frames frames with reflections off, then ray-traced at full and half resolution,
    /// each with and without the decals at their hit points, then in screen space, then off
    /// again (the first run warms up).
    #[arg(long)]
    compare_reflections: bool,
    /// What lights the scene from all around: sky (procedural, its sun the scene's sun),
    /// none (a flat ambient colour), or the path of an HDR map (an equirectangular Radiance
    /// .hdr, or a .ktx2 cube map or equirectangular map in a floating-point format); a map that
    /// cannot be loaded is reported and the sky stands in.
    #[arg(long, default_value = "sky")]
    environment: String,
    /// Multiplier of the environment's radiance.
    #[arg(long, default_value_t = 1.0)]
    environment_intensity: f32,
    /// Turn of the environment map about the vertical axis, in degrees.
    #[arg(long, default_value_t = 0.0)]
    environment_rotation: f32,
    /// Face size of the environment's cube maps in texels (32 to 2048).
    #[arg(long, default_value_t = render::RendererSettings::default().environment_resolution)]
    environment_resolution: u32,
    /// The display transform's tone mapper: neutral (Khronos PBR Neutral), aces (Hill's fit),
    /// agx.
    #[arg(long, default_value = "neutral", value_parser = parse_tonemap)]
    tonemap: render::Tonemapper,
    /// No bloom.
    #[arg(long)]
    no_bloom: bool,
    /// How much of the image bloom replaces by its blurred copy (0 to 1).
    #[arg(long, default_value_t = render::BloomSettings::default().intensity)]
    bloom_intensity: f32,
    /// Ambient occlusion: off, ray_traced (screen space where the device cannot trace rays),
    /// screen_space.
    #[arg(long, default_value = "ray_traced", value_parser = parse_occlusion)]
    ao: render::OcclusionMethod,
    /// How far ambient occluders count, in metres.
    #[arg(long, default_value_t = render::OcclusionSettings::default().radius)]
    ao_radius: f32,
    /// Rays per pixel of traced ambient occlusion.
    #[arg(long, default_value_t = render::OcclusionSettings::default().rays)]
    ao_rays: u32,
    /// Run --frames frames with each ambient occlusion method in turn (off, ray_traced,
    /// screen_space; the first run warms up and is repeated at the end).
    #[arg(long)]
    compare_ao: bool,
    /// Auto-exposure from the image's luminance histogram instead of the camera's exposure.
    #[arg(long)]
    auto_exposure: bool,
    /// Stops auto-exposure adds to the exposure it finds (positive brightens).
    #[arg(long, default_value_t = 0.0)]
    exposure_compensation: f32,
    /// The camera's exposure as an exposure value at ISO 100 (default: the scene's exposure).
    #[arg(long)]
    ev100: Option<f32>,
    /// Run --frames frames with no environment, the procedural sky, then the --environment map
    /// if one is given, then none again (the first run warms up).
    #[arg(long)]
    compare_environment: bool,
    /// Run --frames frames with each culling mode in turn (off, frustum, occlusion).
    #[arg(long)]
    compare_culling: bool,
    /// Instances of --bench-scene many-instances (props) and behind-wall (boxes behind the wall).
    #[arg(long, default_value_t = sandbox::bench::MANY_INSTANCES)]
    instances: usize,
    /// Particles --bench-scene particles keeps alive (the pool is made at least this large).
    #[arg(long, default_value_t = sandbox::bench::PARTICLES)]
    particles: u32,
    /// No particle effects: no sparks from shots, no dust from the walking character, no rain.
    #[arg(long)]
    no_particles: bool,
    /// Rain over the courtyard: streaked drops, some leaving wet spots that the reflections
    /// show the sky in (GPU-born decals).
    #[arg(long)]
    rain: bool,
    /// --bench-scene particles: each particle leaves a small decal where it first lands.
    #[arg(long)]
    particle_decals: bool,
    /// Every point and spot light's radius in metres (soft ray-traced shadows; 0: hard).
    #[arg(long, value_parser = parse_light_radius)]
    light_radius: Option<f32>,
    /// How glTF textures are imported: `bc` (block-compressed by role, with mips, cached) or
    /// `rgba8` (decoded at every load, 4 bytes a texel).
    #[arg(long, default_value = "bc", global = true)]
    textures: String,
    /// Folder of the compressed-texture cache (default `$XDG_CACHE_HOME/ecs-decals/textures`,
    /// else `~/.cache/ecs-decals/textures`; `off`: compress at every load).
    #[arg(long, global = true)]
    asset_cache: Option<PathBuf>,
    /// MiB the scene's textures may hold on the GPU: over it, the finest levels of the largest
    /// textures are dropped as they upload, with one warning (default: no budget).
    #[arg(long)]
    texture_budget: Option<f64>,
    #[command(subcommand)]
    command: Option<Command>,
}

/// Commands besides playing.
#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Compress the textures of glTF files into the texture cache ahead of time (what their
    /// first load would do), or with `--measure` time RGBA8, first and cached loads and report
    /// their texture bytes as JSON.
    Bake {
        /// The .gltf/.glb files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Measure instead: each file loaded as RGBA8, compressed into an empty scratch cache,
        /// then from that cache.
        #[arg(long)]
        measure: bool,
    },
}

fn parse_aa(s: &str) -> Result<render::AntiAliasing, String> {
    render::AntiAliasing::from_name(s).ok_or_else(|| format!("unknown anti-aliasing {s:?} (none, fxaa, smaa, taa, msaa2, msaa4, msaa8)"))
}

fn parse_tonemap(s: &str) -> Result<render::Tonemapper, String> {
    render::Tonemapper::from_name(s).ok_or_else(|| format!("unknown tone mapper {s:?} (neutral, aces, agx)"))
}

fn parse_occlusion(s: &str) -> Result<render::OcclusionMethod, String> {
    render::OcclusionMethod::from_name(s).ok_or_else(|| format!("unknown ambient occlusion {s:?} (off, ray_traced, screen_space)"))
}

fn parse_reflections(s: &str) -> Result<render::ReflectionMode, String> {
    render::ReflectionMode::from_name(s).ok_or_else(|| format!("unknown reflections {s:?} (off, ray_traced, screen_space)"))
}

fn parse_refit_pixels(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(px) if px.is_finite() && px >= 0.0 => Ok(px),
        _ => Err(format!("--refit-pixels takes a number of pixels, 0 or more (0: refit every frame), not {s:?}")),
    }
}

fn parse_light_radius(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(r) if r.is_finite() && r >= 0.0 => Ok(r),
        _ => Err(format!("--light-radius takes metres, 0 or more (0: hard shadows), not {s:?}")),
    }
}

fn parse_lod_pixels(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(p) if p.is_finite() && p >= 0.0 => Ok(p),
        _ => Err(format!("--lod-pixels takes a number of pixels, 0 or more (0: off), not {s:?}")),
    }
}

fn parse_culling(s: &str) -> Result<render::CullingMode, String> {
    render::CullingMode::from_name(s).ok_or_else(|| format!("unknown culling mode {s:?} (off, frustum, occlusion)"))
}

fn parse_debug_view(s: &str) -> Result<DebugView, String> {
    Ok(match s {
        "lit" => DebugView::Lit,
        "decal-heatmap" => DebugView::DecalHeatmap,
        "albedo" => DebugView::Albedo,
        "normal" => DebugView::Normal,
        "roughness-metallic" => DebugView::RoughnessMetallic,
        "light-heatmap" => DebugView::LightHeatmap,
        "shadow-rays" => DebugView::ShadowRays,
        "depth-normals" => DebugView::DepthNormals,
        "reflections" => DebugView::Reflections,
        "ambient-occlusion" => DebugView::AmbientOcclusion,
        "decal-floor" => DebugView::DecalFloor,
        "lod" => DebugView::Lod,
        _ => {
            return Err(format!(
                "unknown view {s:?} (lit, decal-heatmap, albedo, normal, roughness-metallic, light-heatmap, shadow-rays, depth-normals, reflections, ambient-occlusion, decal-floor, lod)"
            ));
        }
    })
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: u32 = w.parse().map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h.parse().map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s} out of range (1..=16384 each way)"));
    }
    Ok((w, h))
}

fn parse_pipeline(s: &str) -> Result<PipelineKind, String> {
    PipelineKind::from_name(s).ok_or_else(|| format!("unknown pipeline {s:?} (forward, forward_plus, deferred, visbuffer)"))
}

fn parse_transparency(s: &str) -> Result<render::TransparencyMethod, String> {
    render::TransparencyMethod::from_name(s)
        .ok_or_else(|| format!("unknown transparency method {s:?} (interlaced, interlaced_pairs, forward, depth_peeling)"))
}

fn parse_light_method(s: &str) -> Result<render::LightMethod, String> {
    render::LightMethod::from_name(s).ok_or_else(|| format!("unknown light method {s:?} (all, tiled, ray_query)"))
}

fn parse_depth_normals(s: &str) -> Result<render::DepthNormals, String> {
    match s {
        "naive" => Ok(render::DepthNormals::Naive),
        "improved" => Ok(render::DepthNormals::Improved),
        _ => Err(format!("unknown normal reconstruction {s:?} (naive, improved)")),
    }
}

fn parse_direct_light(s: &str) -> Result<render::DirectLight, String> {
    render::DirectLight::ALL
        .into_iter()
        .find(|d| d.name() == s)
        .ok_or_else(|| format!("unknown direct-light method {s:?} (exhaustive, stochastic, auto)"))
}

fn parse_decal_method(s: &str) -> Result<DecalMethod, String> {
    DecalMethod::from_name(s)
        .ok_or_else(|| format!("unknown decal method {s:?} (ray_query, ray_query_compute, ray_pipeline, clustered, deferred, off)"))
}

fn parse_tier(s: &str) -> Result<Tier, String> {
    Tier::from_name(s).ok_or_else(|| format!("unknown tier {s:?} (ray_query, ray_tracing_pipeline, none)"))
}

fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()))
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let import = sandbox::assets::import_options(&cli.textures, cli.asset_cache.as_deref(), true)?;
    if let Some(Command::Bake { files, measure }) = &cli.command {
        for file in files {
            if *measure {
                let report = sandbox::assets::measure_import(file, &std::env::temp_dir())?;
                println!("{}", serde_json::to_string(&report)?);
            } else {
                println!("{}", sandbox::assets::bake(file, &import)?);
            }
        }
        return Ok(());
    }
    if cli.soak {
        let size = if std::env::args().any(|a| a.starts_with("--size")) { cli.size } else { (48, 32) };
        let mut config =
            sandbox::soak::SoakConfig { seed: cli.seed, frames: cli.frames, cycles: cli.soak_cycles, size, ..Default::default() };
        config.heap_bytes = Some(|| ALLOCATOR.allocated() as u64);
        config.validation = !cli.soak_without_validation;
        if std::env::args().any(|a| a.starts_with("--tier")) {
            config.tiers = vec![cli.tier];
        }
        let report = sandbox::soak::run(&config)?;
        println!("{}", serde_json::to_string_pretty(&report)?);
        let failures = report.failures();
        if !failures.is_empty() {
            bail!("the soak failed:\n{}", failures.join("\n"));
        }
        println!("soak passed: {} frames in {:.0} s", report.frames_rendered, report.seconds);
        return Ok(());
    }
    let windowed = !cli.headless && sandbox::window::display_available();
    if !cli.headless && !windowed {
        eprintln!("sandbox: no display available (neither DISPLAY nor WAYLAND_DISPLAY is set); playing a short scene headless instead");
    }
    let screenshot = cli.screenshot.clone().or_else(|| (!cli.headless).then(|| PathBuf::from("out/sandbox.png")));
    let (mut environment, environment_error) = engine::environment::Environment::from_argument(&cli.environment);
    if let Some(e) = environment_error {
        eprintln!("sandbox: {e}; the procedural sky lights the scene instead");
    }
    environment.intensity = cli.environment_intensity;
    environment.rotation = cli.environment_rotation.to_radians();
    let opts = HeadlessOptions {
        frames: cli.frames,
        size: cli.size,
        scene: SceneSource::parse(&cli.scene),
        character: match cli.character.as_deref() {
            Some("none") => None,
            Some(path) => Some(PathBuf::from(path)),
            None => sandbox::character::default_character(),
        },
        character_clip: cli.character_clip.clone(),
        import,
        texture_budget: cli.texture_budget.map_or(0, |mib| (mib * 1024.0 * 1024.0) as u64),
        screenshot: screenshot.clone(),
        stats: cli.stats.clone(),
        pipeline: cli.pipeline,
        decal_method: cli.decal_method,
        max_tier: cli.tier,
        decals: cli.decals,
        decal_seed: cli.decal_seed,
        debug_view: cli.debug_view,
        show_decal_boxes: cli.decal_boxes,
        move_decals_percent: cli.move_decals,
        move_camera: cli.move_camera,
        churn_decals: cli.churn_decals,
        bench_scene: cli.bench_scene.as_deref().map(sandbox::bench::BenchScene::parse).transpose()?,
        compare: cli.compare,
        compare_lights: cli.compare_lights,
        compare_light_methods: cli.compare_light_methods,
        compare_transparency: cli.compare_transparency,
        compute_shading: !cli.fragment_shading,
        decals_in_forward_shading: cli.decals_in_forward_shading,
        aa: cli.aa,
        taa_sharpen: cli.taa_sharpen,
        reflections: render::ReflectionSettings {
            mode: cli.reflections,
            roughness_cutoff: cli.reflection_cutoff,
            half_resolution: cli.half_res_reflections,
            decals_at_hits: !cli.no_reflection_decals,
        },
        compare_reflections: cli.compare_reflections,
        transparency: cli.transparency,
        lights: render::LightSettings {
            method: cli.lights,
            tile_size: cli.tile_size,
            cull_aabb: !cli.no_light_aabb,
            cull_depth_mask: !cli.no_light_depth_mask,
            shadows: !cli.no_shadows,
            shadow_ray_culling: !cli.no_shadow_ray_culling,
            normals: cli.depth_normals,
            coloured_shadows: !cli.opaque_glass_shadows,
            shadow_maps: cli.shadow_maps,
            direct_light: cli.direct_light,
        },
        shadow_maps: render::ShadowMapBudget { tile: cli.shadow_map_size, tiles: cli.shadow_map_tiles, ..Default::default() },
        culling: cli.culling,
        lod_pixels: cli.lod_pixels,
        refit_pixels: cli.refit_pixels,
        skin_levels: !cli.full_skinning,
        compare_lod: cli.compare_lod,
        reuse_commands: !cli.record_every_frame,
        pipelined: cli.pipelined,
        animation_budget: cli.animation_budget,
        bone_entities: cli.bone_entities,
        gpu_idle_between_frames: cli.gpu_idle_between_frames,
        compare_culling: cli.compare_culling,
        environment,
        environment_resolution: cli.environment_resolution,
        compare_environment: cli.compare_environment,
        tonemapper: cli.tonemap,
        bloom: render::BloomSettings { enabled: !cli.no_bloom, intensity: cli.bloom_intensity },
        occlusion: render::OcclusionSettings { method: cli.ao, radius: cli.ao_radius, rays: cli.ao_rays },
        compare_occlusion: cli.compare_ao,
        compare_direct_light: cli.compare_direct_light,
        exposure: render::AutoExposure { enabled: cli.auto_exposure, compensation: cli.exposure_compensation, ..Default::default() },
        ev100: cli.ev100,
        instances: cli.instances,
        particles: cli.particles,
        effects: !cli.no_particles,
        rain: cli.rain,
        particle_decals: cli.particle_decals,
        light_radius: cli.light_radius,
    };
    if windowed {
        let window_opts = sandbox::window::WindowOptions { base: opts, exit_after: cli.exit_after, resize_to: cli.resize_to };
        return sandbox::window::run_windowed(window_opts);
    }
    if let Some(dir) = screenshot.as_ref().and_then(|p| p.parent()).filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    // Without a display, the run command still plays: the built-in demo script.
    let script = match (&cli.script, cli.headless) {
        (Some(path), _) => Some(Script::load(path)?),
        (None, false) => Some(Script::parse(DEMO_SCRIPT).expect("the built-in demo script parses")),
        (None, true) => None,
    };
    if let Some(script) = script {
        let mut opts = opts;
        if !cli.headless {
            opts.frames = opts.frames.min(30); // after the script: a short settle
        }
        let summary = run_scripted(&opts, script)?;
        report(&summary.app, &summary.frames, &screenshot, &cli.stats, &summary.validation_errors)?;
        println!("game: {}", serde_json::to_string(&summary.game)?);
        return Ok(());
    }
    let summary = run(&opts)?;
    if let (true, Some(stats)) = (
        cli.compare
            || cli.compare_lights
            || cli.compare_light_methods
            || cli.compare_transparency
            || cli.compare_culling
            || cli.compare_lod
            || cli.compare_reflections
            || cli.compare_direct_light,
        &cli.stats,
    ) {
        let (csv, svg) = sandbox::charts::write(stats, &sandbox::charts::run_medians(&summary.frames))?;
        println!("per-pass medians: {} and {}", csv.display(), svg.display());
    }
    report(&summary.app, &summary.frames, &screenshot, &cli.stats, &summary.validation_errors)
}

/// The demo the run command plays when there is no display (assets/scripts/demo.txt).
const DEMO_SCRIPT: &str = include_str!("../../assets/scripts/demo.txt");

fn report(
    app: &engine::app::App,
    frames: &[serde_json::Value],
    screenshot: &Option<PathBuf>,
    stats: &Option<PathBuf>,
    validation_errors: &[String],
) -> Result<()> {
    let renderer = &app.world.resource::<plugins::GpuRenderer>().0;
    println!("device: {} (tier {})", renderer.device_name(), renderer.tier().name());
    if let Some(last) = frames.last() {
        println!("last frame: {last}");
    }
    if let Some(p) = screenshot {
        println!("screenshot: {}", p.display());
    }
    if let Some(p) = stats {
        println!("stats: {} ({} frames)", p.display(), frames.len());
    }
    if !validation_errors.is_empty() {
        bail!("{} Vulkan validation errors, first: {}", validation_errors.len(), validation_errors[0]);
    }
    Ok(())
}
