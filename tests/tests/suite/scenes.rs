//! Whole scenes on the GPU (lavapipe at small sizes): the generated courtyard and the glTF models
//! in ../shared/assets/gltf render without validation errors and with a non-degenerate image.
//!
//! "Non-degenerate" is checked as: no NaN or infinity in the HDR target; coverage (pixels with
//! geometry, from the depth target: the procedural sky fills the rest) and luma variance above
//! stated floors; and a frame in which nothing changed uploads nothing.

use sandbox::headless::{HeadlessOptions, SceneSource, run};
use tests::{image_stats, shared_gltf_dir};

fn check_scene(scene: SceneSource, min_coverage: f64) {
    let opts = HeadlessOptions { frames: 4, size: (160, 120), scene, ..Default::default() };
    let mut summary = run(&opts).expect("scene renders");
    assert!(summary.validation_errors.is_empty(), "validation errors: {:#?}", summary.validation_errors);
    let renderer = &mut summary.app.world.resource_mut::<plugins::GpuRenderer>().into_inner().0;
    let hdr = renderer.read_hdr().expect("readback");
    let nan = hdr.iter().flatten().filter(|v| v.is_nan()).count();
    let inf = hdr.iter().flatten().filter(|v| v.is_infinite()).count();
    assert!(nan == 0 && inf == 0, "no NaN ({nan}) or infinity ({inf}) in the HDR target");
    let depth = renderer.read_depth().expect("readback");
    let coverage = depth.iter().filter(|&&d| d > 0.0).count() as f64 / depth.len() as f64;
    let stats = image_stats(&summary.pixels, [0, 0, 0]);
    eprintln!("coverage {coverage:.3}, {stats:?}");
    assert!(coverage >= min_coverage, "geometry covers at least {min_coverage}: {coverage:.3}");
    assert!(stats.luma_variance > 0.002, "the image is not flat: {stats:?}");
    assert!(stats.mean_luma > 0.05 && stats.mean_luma < 0.95, "neither black nor blown out: {stats:?}");

    assert_eq!(summary.frames.len(), 4, "one stats object per frame");
    let first = &summary.frames[0]["counters"];
    assert!(first["bytes_uploaded"].as_u64().unwrap() > 0, "the first frame uploads the scene");
    for later in &summary.frames[1..] {
        assert_eq!(later["counters"]["bytes_uploaded"], 0, "a frame with no change uploads nothing: {later}");
        assert_eq!(later["counters"]["records_written"], 0);
        for pass in ["prepass", "forward", "tonemap", "total"] {
            assert!(later["gpu_ms"][pass].as_f64().is_some_and(|ms| ms > 0.0), "GPU time for {pass}: {later}");
        }
        // Passes share their boundary timestamps, so the frame is the sum of its passes.
        let times = later["gpu_ms"].as_object().expect("gpu_ms is an object");
        let passes: f64 = times.iter().filter(|(name, _)| *name != "total").filter_map(|(_, ms)| ms.as_f64()).sum();
        let total = times["total"].as_f64().unwrap();
        // (Each time is rounded to 1e-4 ms in the statistics.)
        let rounding = 5e-5 * times.len() as f64;
        assert!((passes - total).abs() <= rounding + 1e-3 * total, "passes sum to {passes} ms, the frame takes {total}: {later}");
    }
}

#[test]
fn default_courtyard_renders() {
    check_scene(SceneSource::Default, 0.5);
}

#[test]
fn damaged_helmet_renders() {
    check_scene(SceneSource::Gltf(shared_gltf_dir().join("DamagedHelmet/DamagedHelmet.glb")), 0.12);
}

#[test]
fn suzanne_renders() {
    check_scene(SceneSource::Gltf(shared_gltf_dir().join("Suzanne/Suzanne.gltf")), 0.12);
}

#[test]
fn a_setting_forces_a_lower_capability_tier() {
    for (tier, name) in [(render::Tier::NoRayTracing, "none"), (render::Tier::RayTracingPipeline, "ray_tracing_pipeline")] {
        let opts = HeadlessOptions { frames: 2, size: (64, 48), max_tier: tier, ..Default::default() };
        let summary = run(&opts).expect("renders at a forced tier");
        assert!(summary.validation_errors.is_empty(), "{:#?}", summary.validation_errors);
        let reported = summary.frames[0]["tier"].as_str().unwrap().to_string();
        // The device may be below the cap (a GPU without ray tracing), never above it.
        let actual = render::Tier::from_name(&reported).expect("a known tier name");
        assert!(actual <= tier, "tier {reported} exceeds the forced cap {name}");
        if summary.app.world.resource::<plugins::GpuRenderer>().0.capabilities().best_tier() >= tier {
            assert_eq!(reported, name, "a device that offers more uses exactly the cap");
        }
    }
}

#[test]
fn statistics_report_the_decal_method_actually_applied_on_every_tier() {
    use render::{DecalMethod, PipelineKind, Tier};
    // Ray-query decals run in the shading of every pipeline alike: one pipeline stands for the
    // ray-query tier; the two fallback tiers share the pipelines between them, so that each
    // pipeline falls back once.
    let runs: [(Tier, &[PipelineKind]); 3] = [
        (Tier::RayQuery, &[PipelineKind::Deferred]),
        (Tier::RayTracingPipeline, &[PipelineKind::Forward, PipelineKind::Deferred]),
        (Tier::NoRayTracing, &[PipelineKind::ForwardPlus, PipelineKind::VisBuffer]),
    ];
    for (tier, pipelines) in runs {
        for &pipeline in pipelines {
            let opts = HeadlessOptions {
                frames: 1,
                size: (32, 24),
                max_tier: tier,
                pipeline,
                decal_method: DecalMethod::RayQuery,
                decals: 20,
                ..Default::default()
            };
            let summary = run(&opts).expect("renders at a forced tier");
            assert!(summary.validation_errors.is_empty(), "{:#?}", summary.validation_errors);
            let actual = Tier::from_name(summary.frames[0]["tier"].as_str().unwrap()).expect("a known tier");
            // Ray-query decals need the ray-query tier; without it clustered decals run, in every
            // pipeline (the ray-tracing-pipeline decal pass only when asked for).
            let expected = match actual {
                Tier::RayQuery => "ray_query",
                Tier::RayTracingPipeline | Tier::NoRayTracing => "clustered",
            };
            let reported = &summary.frames[0]["decal_method"];
            assert_eq!(reported, expected, "{} on tier {}", pipeline.name(), actual.name());
            if expected == "clustered" {
                assert!(summary.frames[0]["gpu_ms"]["decal_pass_clustered"].is_number(), "the fallback draws: {}", summary.frames[0]);
            }
        }
    }
}

#[test]
fn a_benchmark_scene_runs_every_pipeline_and_decal_method_in_one_run() {
    let opts = HeadlessOptions {
        frames: 2,
        size: (96, 54),
        bench_scene: Some(sandbox::bench::BenchScene::FewBlendedDecals),
        compare: true,
        ..Default::default()
    };
    let summary = run(&opts).expect("the comparison runs");
    assert!(summary.validation_errors.is_empty(), "{:#?}", summary.validation_errors);
    let set = sandbox::headless::compare_set(summary.app.world.resource::<plugins::GpuRenderer>().0.ray_support());
    assert_eq!(set.len(), sandbox::headless::COMPARE_SET.len(), "lavapipe runs every method");
    assert_eq!(summary.frames.len(), 2 * set.len());
    for (i, (pipeline, method)) in set.iter().enumerate() {
        for frame in &summary.frames[i * 2..i * 2 + 2] {
            assert_eq!(frame["pipeline"], pipeline.name());
            assert_eq!(frame["decal_method"], method.name());
            let passes: &[&str] = match pipeline {
                render::PipelineKind::Forward | render::PipelineKind::ForwardPlus => &["prepass", "light_cull", "forward"],
                render::PipelineKind::Deferred => &["gbuffer", "light_cull", "lighting"],
                render::PipelineKind::VisBuffer => &["visibility", "light_cull", "visbuffer_shade"],
            };
            for pass in passes {
                assert!(frame["gpu_ms"][pass].as_f64().is_some_and(|ms| ms > 0.0), "{pass} timed: {frame}");
            }
            assert_eq!(frame["gpu_ms"]["deferred_decals"].is_number(), *method == render::DecalMethod::DeferredDecals, "{frame}");
            let decal_pass = match method {
                render::DecalMethod::RayPipeline => Some("decal_pass_ray_pipeline"),
                render::DecalMethod::RayQueryCompute => Some("decal_pass_ray_query"),
                render::DecalMethod::Clustered => Some("decal_pass_clustered"),
                _ => None,
            };
            if let Some(pass) = decal_pass {
                assert!(frame["gpu_ms"][pass].as_f64().is_some_and(|ms| ms > 0.0), "{pass} timed: {frame}");
            }
            assert_eq!(frame["counters"]["decals"], 6);
        }
    }
}

/// Suzanne scaled to 2 cm (a BoomBox-sized model) and to 200 m (a Sponza-sized level) is framed
/// alike by `engine::scene::frame_scene`: the camera's near plane follows the model's size, so
/// the tiny one is not clipped away, and the model fills a similar share of the image.
#[test]
fn models_of_any_scale_are_framed_alike() {
    use engine::prelude::*;
    // The default clear colour (0.35, 0.45, 0.6) after tone mapping and sRGB encoding: what
    // `tests::gpu_app`, with no environment, shows where nothing is drawn.
    const CLEAR_DISPLAY_COLOR: [u8; 3] = [151, 171, 197];
    let (mut coverages, mut radii) = (Vec::new(), Vec::new());
    for scale in [0.01, 1.0, 100.0] {
        let mut app = tests::gpu_app(128, 96, plugins::RenderSettings::default());
        let root = engine::gltf::load(&shared_gltf_dir().join("Suzanne/Suzanne.gltf")).expect("Suzanne loads").spawn(&mut app.world);
        app.world.get_mut::<Transform>(root).expect("the scene root has a transform").scale = Vec3::splat(scale);
        let framed = engine::scene::frame_scene(&mut app.world);
        assert!(framed.camera_spawned, "{scale}: {framed:?}");
        radii.push(framed.radius / scale);
        let near = app.world.query::<&Camera>().iter(&app.world).next().expect("a camera").near;
        assert!(near <= framed.radius * 0.011, "{scale}: near plane {near} for a radius of {}", framed.radius);
        app.update();
        tests::assert_no_validation_errors(&mut app);
        let pixels = tests::renderer(&mut app).read_display().expect("readback");
        let stats = image_stats(&pixels, CLEAR_DISPLAY_COLOR);
        eprintln!("scale {scale}: {stats:?}");
        coverages.push(stats.coverage);
    }
    assert!(radii.iter().all(|r| (r / radii[1] - 1.0).abs() < 1e-3), "the bounds scale with the model: {radii:?}");
    for (scale, coverage) in [0.01, 1.0, 100.0].iter().zip(&coverages) {
        assert!(*coverage > 0.1 && (coverage - coverages[1]).abs() < 0.05, "scale {scale}: coverage {coverage} vs {}", coverages[1]);
    }
}
