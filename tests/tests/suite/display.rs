//! The display transform after the HDR image is lit (`render::bloom`, `shaders/include/color.glsl`):
//!
//! - bloom keeps the image's energy: the HDR target's sum with bloom at full intensity is within
//!   1 % of its sum without (a lit scene; Karis's average on the first downsample takes energy
//!   from lone bright pixels by design, which this scene has none of), while it does blur;
//! - each tone mapper turns a known radiance into the display value a CPU evaluation of its
//!   published formula gives, within one 8-bit step, at two exposures, one of them set as EV100;
//! - auto-exposure exposes a uniform sky for 18 % grey at once, follows a hundredfold change at
//!   its rate, and shows the same grey once adapted; compensation doubles it per stop;
//! - emissive materials emit in every pipeline, and emissive glass through every way of drawing
//!   glass (composited as colour × opacity).

// The published constants are kept as their authors wrote them.
#![allow(clippy::excessive_precision)]

use engine::environment::{Environment, EnvironmentSource};
use engine::prelude::*;
use plugins::RenderSettings;
use render::{BloomSettings, PipelineKind, RendererSettings, Tonemapper};
use tests::{TEST_SHADOW_MAPS, assert_no_validation_errors, gpu_app_with, renderer};

fn app(w: u32, h: u32, settings: RenderSettings, environment: Environment) -> App {
    let renderer_settings = RendererSettings { shadow_maps: TEST_SHADOW_MAPS, environment_resolution: 32, ..Default::default() };
    let bloom = settings.bloom;
    let mut app = gpu_app_with(w, h, RenderSettings { clear_color: [0.0; 4], ..settings }, &renderer_settings);
    app.world.resource_mut::<RenderSettings>().bloom = bloom; // the harness turns it off
    app.insert_resource(environment);
    app
}

fn luminance_sum(hdr: &[[f32; 4]]) -> (f64, f64) {
    let l: Vec<f64> = hdr.iter().map(|p| (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) as f64).collect();
    let mean = l.iter().sum::<f64>() / l.len() as f64;
    let variance = l.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / l.len() as f64;
    (l.iter().sum(), variance)
}

#[test]
fn bloom_keeps_the_energy_of_the_image_it_blurs() {
    let (w, h) = (128u32, 96u32);
    let render = |bloom: BloomSettings| {
        let settings = RenderSettings { pipeline: PipelineKind::Deferred, bloom, ..Default::default() };
        let mut app = app(w, h, settings, Environment { source: EnvironmentSource::Uniform(Vec3::splat(0.6)), ..Default::default() });
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::uv_sphere(0.5, 32, 16));
        for (i, albedo) in [0.05f32, 0.9, 0.3].into_iter().enumerate() {
            let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(
                Vec4::new(albedo, albedo, 0.8 * albedo, 1.0),
                0.0,
                0.7,
            ));
            app.world.spawn((MeshInstance { mesh, material }, Transform::from_xyz(i as f32 - 1.0, 0.0, 0.0)));
        }
        app.world
            .spawn((PointLight { color: Vec3::ONE, intensity: 6.0, range: Some(6.0), radius: 0.0 }, Transform::from_xyz(0.0, 1.5, 1.5)));
        app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.3, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
        app.update();
        app.update();
        let hdr = renderer(&mut app).read_hdr().expect("readback");
        assert_no_validation_errors(&mut app);
        luminance_sum(&hdr)
    };
    let (before, variance_before) = render(BloomSettings::OFF);
    let (after, variance_after) = render(BloomSettings { enabled: true, intensity: 1.0 });
    let change = (after - before) / before;
    println!("energy {before:.1} → {after:.1} ({:+.3} %), variance {variance_before:.5} → {variance_after:.5}", change * 100.0);
    assert!(change.abs() < 0.01, "bloom keeps the energy within 1 %: {before} → {after}");
    assert!(variance_after < 0.75 * variance_before, "and it blurs: variance {variance_before} → {variance_after}");
}

/// Khronos PBR Neutral (the reference listing of the Khronos specification).
fn pbr_neutral(c: Vec3) -> Vec3 {
    let start = 0.8 - 0.04;
    let desaturation = 0.15;
    let x = c.min_element();
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let c = c - Vec3::splat(offset);
    let peak = c.max_element();
    if peak < start {
        return c;
    }
    let d = 1.0 - start;
    let new_peak = 1.0 - d * d / (peak + d - start);
    let c = c * (new_peak / peak);
    let g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    c.lerp(Vec3::splat(new_peak), g)
}

/// Hill's ACES fit (his HLSL matrices, written row by row), after the 1/0.6 exposure bias.
fn aces_fitted(c: Vec3) -> Vec3 {
    let rows = |m: [f32; 9]| Mat3::from_cols_array(&m).transpose();
    let input = rows([0.59719, 0.35458, 0.04823, 0.07600, 0.90834, 0.01566, 0.02840, 0.13383, 0.83777]);
    let output = rows([1.60475, -0.53108, -0.07367, -0.10208, 1.10813, -0.00605, -0.00327, -0.07276, 1.07602]);
    let v = input * (c / 0.6);
    let a = v * (v + Vec3::splat(0.0245786)) - Vec3::splat(0.000090537);
    let b = v * (0.983729 * v + Vec3::splat(0.4329510)) + Vec3::splat(0.238081);
    (output * (a / b)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// AgX in Wrensch's minimal fit.
fn agx(c: Vec3) -> Vec3 {
    let inset = Mat3::from_cols_array(&[
        0.842479062253094,
        0.0423282422610123,
        0.0423756549057051,
        0.0784335999999992,
        0.878468636469772,
        0.0784336,
        0.0792237451477643,
        0.0791661274605434,
        0.879142973793104,
    ]);
    let outset = Mat3::from_cols_array(&[
        1.19687900512017,
        -0.0528968517574562,
        -0.0529716355144438,
        -0.0980208811401368,
        1.15190312990417,
        -0.0980434501171241,
        -0.0990297440797205,
        -0.0989611768448433,
        1.15107367264116,
    ]);
    let (min_ev, max_ev) = (-12.47393f32, 4.026069f32);
    let x = (inset * c).max(Vec3::splat(1e-10));
    let x = Vec3::new(x.x.log2(), x.y.log2(), x.z.log2()).clamp(Vec3::splat(min_ev), Vec3::splat(max_ev));
    let x = (x - Vec3::splat(min_ev)) / (max_ev - min_ev);
    let poly =
        |x: f32| 15.5 * x.powi(6) - 40.14 * x.powi(5) + 31.96 * x.powi(4) - 6.868 * x.powi(3) + 0.4298 * x.powi(2) + 0.1191 * x - 0.00232;
    let y = (outset * Vec3::new(poly(x.x), poly(x.y), poly(x.z))).clamp(Vec3::ZERO, Vec3::ONE);
    Vec3::new(y.x.powf(2.2), y.y.powf(2.2), y.z.powf(2.2))
}

fn srgb8(linear: f32) -> f32 {
    let l = linear.clamp(0.0, 1.0);
    255.0 * if l <= 0.0031308 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 }
}

#[test]
fn each_tone_mapper_matches_its_formula() {
    let (w, h) = (16u32, 16u32);
    // One app, its settings changed between frames: nothing but the sky, so every pixel shows
    // the uniform environment's radiance.
    let settings = RenderSettings { bloom: BloomSettings::OFF, ..Default::default() };
    let mut app = app(w, h, settings, Environment::default());
    let camera = app.world.spawn((Camera::default(), Transform::default())).id();
    for radiance in [Vec3::new(0.05, 0.3, 0.9), Vec3::new(6.0, 1.5, 0.2)] {
        app.insert_resource(Environment { source: EnvironmentSource::Uniform(radiance), ..Default::default() });
        for (exposure, ev100) in [(1.0, None), (Camera::exposure_from_ev100(-1.5), Some(-1.5f32))] {
            app.world.get_mut::<Camera>(camera).expect("the camera").exposure = exposure;
            for tonemapper in Tonemapper::ALL {
                app.world.resource_mut::<RenderSettings>().tonemapper = tonemapper;
                app.update();
                let pixels = renderer(&mut app).read_display().expect("readback");
                assert_no_validation_errors(&mut app);
                let c = radiance * exposure;
                let want = match tonemapper {
                    Tonemapper::PbrNeutral => pbr_neutral(c),
                    Tonemapper::AcesFitted => aces_fitted(c),
                    Tonemapper::AgX => agx(c),
                };
                let want = [srgb8(want.x), srgb8(want.y), srgb8(want.z)];
                let got = &pixels[((h / 2 * w + w / 2) * 4) as usize..][..3];
                for ch in 0..3 {
                    assert!(
                        (got[ch] as f32 - want[ch]).abs() <= 1.5,
                        "{tonemapper:?}, radiance {radiance}, exposure {exposure} (EV100 {ev100:?}): got {got:?}, want {want:?}"
                    );
                }
            }
        }
    }
}

/// The shader's bin centre for luminance `l` (`shaders/include/exposure.glsl`).
fn exposure_bin_log2(l: f32) -> f32 {
    let (bins, offset, range) =
        (render::layout::EXPOSURE_BINS as f32, render::layout::EXPOSURE_LOG2_OFFSET as f32, render::layout::EXPOSURE_LOG2_RANGE as f32);
    let t = (l.log2() + offset) / range;
    let bin = 1.0 + ((t * (bins - 1.0)).floor()).min(bins - 2.0);
    (bin - 0.5) / (bins - 1.0) * range - offset
}

#[test]
fn auto_exposure_adapts_to_the_scene_luminance_at_its_rate() {
    // Nothing but a uniform sky of luminance 0.5, then 50: auto-exposure puts it at mid-grey at
    // once on its first frame, then follows the hundredfold change by 1 − e^(−rate · dt) a frame
    // (the harness's fixed step, 16 ms), until the display shows the same grey as before.
    let (w, h) = (16u32, 16u32);
    let settings = RenderSettings { exposure: render::AutoExposure { enabled: true, ..Default::default() }, ..Default::default() };
    let sky = |intensity| Environment { source: EnvironmentSource::Uniform(Vec3::splat(0.5)), intensity, rotation: 0.0 };
    let mut app = app(w, h, settings, sky(1.0));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 3.0)));
    let target = |luminance: f32, compensation: f32| exposure_bin_log2(luminance) + 3.0 - compensation;
    app.update();
    let first = renderer(&mut app).read_exposure().unwrap().expect("auto-exposure ran");
    assert_eq!(first.frames, 1);
    assert!((first.ev100 - target(0.5, 0.0)).abs() < 1e-4, "first frame: at once, {} vs {}", first.ev100, target(0.5, 0.0));
    assert!((first.exposure * first.ev100.exp2() / 1.44 - 1.0).abs() < 1e-4);
    assert!((first.exposure * 0.5 / 0.18).log2().abs() < 0.1, "18 % grey within half a bin: exposure {}", first.exposure);
    let grey = renderer(&mut app).read_display().unwrap()[0];

    app.insert_resource(sky(100.0));
    app.update();
    let step = renderer(&mut app).read_exposure().unwrap().unwrap();
    let rate = render::AutoExposure::default().rate;
    let expected = first.ev100 + (target(50.0, 0.0) - first.ev100) * (1.0 - (-rate * 0.016f32).exp());
    assert!((step.ev100 - expected).abs() < 1e-3, "one frame of adaptation: {} vs {expected}", step.ev100);
    for _ in 0..200 {
        app.update();
    }
    let adapted = renderer(&mut app).read_exposure().unwrap().unwrap();
    assert!((adapted.ev100 - target(50.0, 0.0)).abs() < 1e-3, "adapted: {} vs {}", adapted.ev100, target(50.0, 0.0));
    let display = renderer(&mut app).read_display().unwrap();
    assert!(display[0].abs_diff(grey) <= 2, "the same grey at a hundred times the light: {} vs {grey}", display[0]);

    // A stop of compensation doubles the exposure (after adapting).
    app.world.resource_mut::<RenderSettings>().exposure.compensation = 1.0;
    for _ in 0..200 {
        app.update();
    }
    let brighter = renderer(&mut app).read_exposure().unwrap().unwrap();
    assert!((brighter.exposure / adapted.exposure - 2.0).abs() < 1e-3, "{} vs {}", brighter.exposure, adapted.exposure);
    assert_no_validation_errors(&mut app);
}

#[test]
fn emissive_materials_emit_in_every_pipeline_and_through_every_kind_of_glass() {
    // No light, no ambient colour, a black background: an emissive opaque square shows exactly
    // its emission, and an emissive pane of opacity 0.5 half of its own (blended surfaces are
    // composited as colour × opacity, their emission included), in every pipeline and with
    // every way of drawing glass.
    let (w, h) = (64u32, 48u32);
    let opaque = Vec3::new(3.0, 1.0, 0.5);
    let pane = Vec3::new(0.0, 2.0, 4.0);
    let mut runs: Vec<(PipelineKind, render::TransparencyMethod)> =
        PipelineKind::ALL.iter().map(|&p| (p, render::TransparencyMethod::default())).collect();
    runs.extend([render::TransparencyMethod::Forward, render::TransparencyMethod::DepthPeeling].map(|t| (PipelineKind::Deferred, t)));
    // One app renders every run: the settings change between them.
    let settings = RenderSettings { ambient: Vec3::ZERO, bloom: BloomSettings::OFF, ..Default::default() };
    let mut app = app(w, h, settings, Environment { source: EnvironmentSource::None, ..Default::default() });
    let square = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(1.5, 1.5, 1, 1.0));
    let mut materials = app.world.resource_mut::<Assets<Material>>();
    let glowing = materials.add(Material { emissive: opaque, ..Material::from_color(Vec4::new(0.0, 0.0, 0.0, 1.0), 0.0, 1.0) });
    let glass = materials.add(Material {
        emissive: pane,
        alpha_mode: AlphaMode::Blend,
        ..Material::from_color(Vec4::new(0.0, 0.0, 0.0, 0.5), 0.0, 1.0)
    });
    app.world.spawn((MeshInstance { mesh: square, material: glowing }, Transform::from_xyz(-1.0, 0.0, 0.0)));
    app.world.spawn((MeshInstance { mesh: square, material: glass }, Transform::from_xyz(1.0, 0.5, 0.0)));
    let view = tests::TopDownView::new(4.0, (w, h));
    view.spawn(&mut app.world);
    for (pipeline, transparency) in runs {
        {
            let mut settings = app.world.resource_mut::<RenderSettings>();
            settings.pipeline = pipeline;
            settings.transparency = transparency;
        }
        app.update();
        let hdr = renderer(&mut app).read_hdr().expect("readback");
        assert_no_validation_errors(&mut app);
        let at = |p: Vec3| {
            let (px, py) = view.pixel_of(p);
            Vec3::from_slice(&hdr[(py * w + px) as usize][..3])
        };
        for (p, want) in
            [(Vec3::new(-1.0, 0.0, 0.0), opaque), (Vec3::new(1.0, 0.5, 0.0), pane * 0.5), (Vec3::new(1.0, 0.5, 0.3), pane * 0.5)]
        {
            let got = at(p);
            assert!((got - want).abs().max_element() < 0.02 * want.max_element(), "{pipeline:?} {transparency:?} at {p}: {got} vs {want}");
        }
    }
}
