//! Image-based light and the sky (`render::environment`), in linear radiance read back from the
//! HDR target and from the environment's cubes:
//!
//! - a white furnace (white diffuse and white metal spheres in a uniform white environment, no
//!   other light) renders within 2 % of the environment in every pipeline;
//! - a mirror sphere shows the map's radiance in the reflected direction, and the sky the map's
//!   radiance in the view direction (turned with the environment's rotation);
//! - the specular cube's levels match a CPU GGX convolution of the same map;
//! - a new source is filtered once, and frames after it refilter nothing;
//! - a missing or malformed `.hdr` gives a clear error, and the sandbox's argument falls back to
//!   the procedural sky;
//! - a KTX2 cube map (written with the `ktx2` crate's serializers) lights the sky with each face
//!   in its direction and orientation, and KTX2 files of the wrong shape or format are clear
//!   errors.

use std::f32::consts::PI;
use std::sync::Arc;

use engine::environment::{Environment, EnvironmentError, EnvironmentSource, HdrImage};
use engine::prelude::*;
use plugins::RenderSettings;
use render::{PipelineKind, RendererSettings};
use tests::{TEST_SHADOW_MAPS, assert_no_validation_errors, gpu_app_with, renderer};

/// Face size of the test environments' cubes: small, for lavapipe.
const RESOLUTION: u32 = 64;

/// The test map's radiance in direction `d` (smooth, so that resampling it into a cube changes it
/// by well under the tolerances, and different in every channel).
fn radiance(d: Vec3) -> Vec3 {
    Vec3::new(1.0 + 0.8 * d.x, 1.0 + 0.8 * d.y, 0.5 + d.z * d.z + 0.5 * d.x * d.y)
}

/// An equirectangular map of [`radiance`]: rows from +Y down, the middle column along +X,
/// longitude growing towards +Z.
fn test_map(width: u32) -> HdrImage {
    let height = width / 2;
    let texels: Arc<[[f32; 3]]> = (0..height)
        .flat_map(|j| (0..width).map(move |i| (i, j)))
        .map(|(i, j)| {
            let phi = ((i as f32 + 0.5) / width as f32 - 0.5) * 2.0 * PI;
            let theta = (j as f32 + 0.5) / height as f32 * PI;
            radiance(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())).to_array()
        })
        .collect();
    HdrImage { width, height, texels, projection: engine::environment::Projection::Equirectangular }
}

fn app(w: u32, h: u32, pipeline: PipelineKind, environment: Environment) -> App {
    app_on(w, h, RenderSettings { pipeline, ..Default::default() }, render::Tier::RayQuery, environment)
}

fn app_on(w: u32, h: u32, settings: RenderSettings, tier: render::Tier, environment: Environment) -> App {
    let settings = RenderSettings { clear_color: [0.0; 4], ..settings };
    let device = render::DeviceSettings { max_tier: tier, ..Default::default() };
    let renderer_settings =
        RendererSettings { device, shadow_maps: TEST_SHADOW_MAPS, environment_resolution: RESOLUTION, ..Default::default() };
    let mut app = gpu_app_with(w, h, settings, &renderer_settings);
    app.insert_resource(environment);
    app
}

fn sphere(app: &mut App, center: Vec3, radius: f32, base: Vec3, metallic: f32, roughness: f32) {
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::uv_sphere(radius, 64, 32));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(base.extend(1.0), metallic, roughness));
    app.world.spawn((MeshInstance { mesh, material }, Transform::from_translation(center)));
}

/// The camera's ray through pixel (px, py) of a `w`×`h` image.
struct View {
    eye: Vec3,
    inv_view_proj: Mat4,
    size: (u32, u32),
}

impl View {
    fn spawn(app: &mut App, eye: Vec3, target: Vec3, size: (u32, u32)) -> View {
        let camera = Camera::default();
        let transform = Transform::from_translation(eye).looking_at(target, Vec3::Y);
        app.world.spawn((camera, transform));
        let view = transform.compute_matrix().inverse();
        View { eye, inv_view_proj: (camera.projection(size.0 as f32 / size.1 as f32) * view).inverse(), size }
    }

    fn ray(&self, px: u32, py: u32) -> Vec3 {
        let ndc_x = (px as f32 + 0.5) / self.size.0 as f32 * 2.0 - 1.0;
        let ndc_y = 1.0 - (py as f32 + 0.5) / self.size.1 as f32 * 2.0;
        (self.inv_view_proj.project_point3(Vec3::new(ndc_x, ndc_y, 0.5)) - self.eye).normalize()
    }
}

fn rgb(p: [f32; 4]) -> Vec3 {
    Vec3::new(p[0], p[1], p[2])
}

fn relative_error(got: Vec3, want: Vec3) -> f32 {
    ((got - want).abs() / want.max(Vec3::splat(0.05))).max_element()
}

#[test]
fn a_white_furnace_holds_in_every_pipeline() {
    let (w, h) = (96u32, 64u32);
    use render::Tier::{RayQuery, RayTracingPipeline};
    let compute = RenderSettings::default();
    let fragment = RenderSettings { compute_shading: false, ..compute.clone() };
    // Forward and Forward+ differ only in how they cull lights, and the furnace has none:
    // forward stands for both. The runs of one tier share an app (the settings change between
    // them; the scene and its environment stay).
    let runs = [
        (PipelineKind::Forward, &compute, RayQuery),
        (PipelineKind::Deferred, &compute, RayQuery),
        (PipelineKind::VisBuffer, &compute, RayQuery),
        // Full-screen fragment shading, and reflection rays from a ray-generation shader.
        (PipelineKind::Deferred, &fragment, RayQuery),
        (PipelineKind::VisBuffer, &fragment, RayQuery),
        (PipelineKind::Deferred, &compute, RayTracingPipeline),
    ];
    let mut apps: Vec<(render::Tier, App, View)> = Vec::new();
    for (pipeline, settings, tier) in runs {
        if !apps.iter().any(|(t, _, _)| *t == tier) {
            let furnace = Environment { source: EnvironmentSource::Uniform(Vec3::ONE), ..Default::default() };
            let mut app = app_on(w, h, settings.clone(), tier, furnace);
            // White diffuse, a glossy white metal the reflection rays trace, a rough white metal
            // (where single scattering alone would lose a fifth of the energy).
            sphere(&mut app, Vec3::new(-1.1, 0.0, 0.0), 0.5, Vec3::ONE, 0.0, 0.6);
            sphere(&mut app, Vec3::new(0.0, 0.0, 0.0), 0.5, Vec3::ONE, 1.0, 0.25);
            sphere(&mut app, Vec3::new(1.1, 0.0, 0.0), 0.5, Vec3::ONE, 1.0, 0.9);
            let view = View::spawn(&mut app, Vec3::new(0.0, 0.4, 3.2), Vec3::ZERO, (w, h));
            apps.push((tier, app, view));
        }
        let (_, app, view) = apps.iter_mut().find(|(t, _, _)| *t == tier).expect("made above");
        let view = &*view;
        {
            let mut s = app.world.resource_mut::<RenderSettings>();
            s.pipeline = pipeline;
            s.compute_shading = settings.compute_shading;
        }
        app.update();
        app.update();
        let hdr = renderer(app).read_hdr().expect("readback");
        assert_no_validation_errors(app);
        let (mut covered, mut worst, mut sum) = (0usize, 0.0f32, 0.0f32);
        for py in 0..h {
            for px in 0..w {
                let d = view.ray(px, py);
                // Pixels well inside a sphere (not its anti-aliased-free silhouette).
                let inside = [-1.1f32, 0.0, 1.1].iter().any(|&x| {
                    let c = Vec3::new(x, 0.0, 0.0) - view.eye;
                    let along = c.dot(d);
                    (c - d * along).length() < 0.45
                });
                let got = rgb(hdr[(py * w + px) as usize]);
                let error = relative_error(got, Vec3::ONE);
                if inside {
                    covered += 1;
                    worst = worst.max(error);
                    sum += error;
                }
            }
        }
        let run = format!("{pipeline:?}, compute shading {}, {tier:?}", settings.compute_shading);
        assert!(covered > 500, "{run}: the spheres cover {covered} pixels");
        let mean = sum / covered as f32;
        assert!(worst < 0.02 && mean < 0.01, "{run}: furnace error mean {mean:.4}, worst {worst:.4} (want < 1 %, 2 %)");
    }
}

#[test]
fn a_mirror_reflects_the_map_and_the_sky_shows_it_turned_with_the_environment() {
    let (w, h) = (96u32, 96u32);
    let map = test_map(256);
    let mut app = app(w, h, PipelineKind::Deferred, Environment { source: EnvironmentSource::Map(map.clone()), ..Default::default() });
    // The reference is the ideal sphere's reflection: the mesh is drawn in full (a coarser level's
    // normals bend the mirror image by up to a few per cent).
    app.world.resource_mut::<RenderSettings>().lod_pixels = 0.0;
    sphere(&mut app, Vec3::ZERO, 1.0, Vec3::ONE, 1.0, 0.0);
    let view = View::spawn(&mut app, Vec3::new(0.0, 0.6, 3.4), Vec3::ZERO, (w, h));
    app.update();
    app.update();
    let check = |app: &mut App, rotation: f32| {
        let hdr = renderer(app).read_hdr().expect("readback");
        assert_no_validation_errors(app);
        let turn = |d: Vec3| Vec3::new(rotation.cos() * d.x - rotation.sin() * d.z, d.y, rotation.sin() * d.x + rotation.cos() * d.z);
        let (mut mirror, mut sky) = ((0usize, 0.0f32, 0.0f32), (0usize, 0.0f32, 0.0f32));
        for py in 0..h {
            for px in 0..w {
                let d = view.ray(px, py);
                let got = rgb(hdr[(py * w + px) as usize]);
                // The ray against the unit sphere.
                let b = view.eye.dot(d);
                let disc = b * b - (view.eye.length_squared() - 1.0);
                let (bucket, want) = if disc < 0.0 {
                    (&mut sky, radiance(turn(d)))
                } else {
                    let p = view.eye + d * (-b - disc.sqrt());
                    if p.dot(-d) < 0.4 {
                        continue; // near the silhouette the polygonal sphere's normals differ
                    }
                    let r = d - 2.0 * d.dot(p) * p;
                    (&mut mirror, radiance(turn(r)))
                };
                let e = relative_error(got, want);
                bucket.0 += 1;
                bucket.1 = bucket.1.max(e);
                bucket.2 += e;
            }
        }
        for (name, (n, worst, sum), (max_worst, max_mean)) in [("mirror", mirror, (0.08, 0.03)), ("sky", sky, (0.03, 0.01))] {
            assert!(n > 1000, "rotation {rotation}: {n} {name} pixels");
            let mean = sum / n as f32;
            assert!(worst < max_worst && mean < max_mean, "rotation {rotation}: {name} error mean {mean:.4}, worst {worst:.4}");
        }
    };
    check(&mut app, 0.0);
    let filtered = |app: &App| app.world.resource::<plugins::RenderStats>().last.environment.filtered;
    assert_eq!(filtered(&app), 1, "the map is filtered once");

    // Turning it costs no filtering.
    app.world.resource_mut::<Environment>().rotation = PI / 2.0;
    app.update();
    app.update();
    check(&mut app, PI / 2.0);
    assert_eq!(filtered(&app), 1, "rotation is applied in shading");

    // A new source is filtered once more.
    app.world.resource_mut::<Environment>().source = EnvironmentSource::Uniform(Vec3::ONE);
    app.update();
    app.update();
    assert_eq!(filtered(&app), 2);
}

/// The radiance a surface of `roughness` facing `n` reflects back along `n` from [`radiance`]:
/// the split sum's prefiltered integral (n = v = r), by many GGX samples.
fn prefiltered(n: Vec3, roughness: f32) -> Vec3 {
    let alpha = (roughness * roughness).max(1e-4);
    let t = if n.z.abs() < 0.999 { Vec3::Z.cross(n).normalize() } else { Vec3::X.cross(n).normalize() };
    let b = n.cross(t);
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
    let count = 64u32;
    for i in 0..count {
        for j in 0..count {
            let (u1, u2) = ((i as f32 + 0.5) / count as f32, (j as f32 + 0.5) / count as f32);
            let phi = 2.0 * PI * u1;
            let cos_theta = ((1.0 - u2) / (1.0 + (alpha * alpha - 1.0) * u2)).sqrt();
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            let h = t * (sin_theta * phi.cos()) + b * (sin_theta * phi.sin()) + n * cos_theta;
            let l = 2.0 * n.dot(h) * h - n;
            let n_dot_l = n.dot(l);
            if n_dot_l > 0.0 {
                sum += radiance(l) * n_dot_l;
                weight += n_dot_l;
            }
        }
    }
    sum / weight
}

/// The direction of texel `(x, y)` of face `face` of a cube level `size` texels wide (Vulkan's
/// face order and orientation).
fn cube_direction(face: usize, x: u32, y: u32, size: u32) -> Vec3 {
    let s = (x as f32 + 0.5) / size as f32 * 2.0 - 1.0;
    let t = (y as f32 + 0.5) / size as f32 * 2.0 - 1.0;
    match face {
        0 => Vec3::new(1.0, -t, -s),
        1 => Vec3::new(-1.0, -t, s),
        2 => Vec3::new(s, 1.0, t),
        3 => Vec3::new(s, -1.0, -t),
        4 => Vec3::new(s, -t, 1.0),
        _ => Vec3::new(-s, -t, -1.0),
    }
    .normalize()
}

#[test]
fn prefiltered_levels_match_a_cpu_convolution_of_the_map() {
    let mut app = app(32, 32, PipelineKind::Forward, Environment { source: EnvironmentSource::Map(test_map(256)), ..Default::default() });
    View::spawn(&mut app, Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, (32, 32));
    app.update();
    assert_no_validation_errors(&mut app);
    let r = renderer(&mut app);
    let level0 = r.read_environment(false, 0).expect("readback").expect("an environment was used");
    assert_eq!(level0.size, RESOLUTION);
    let mut levels = 0;
    while let Ok(Some(_)) = r.read_environment(true, levels) {
        levels += 1;
    }
    assert_eq!(levels, 6, "roughness steps of 0.2");
    let mut worst = 0.0f32;
    // The radiance cube's level 0 is the map.
    for face in 0..6 {
        for (x, y) in [(3, 5), (32, 32), (60, 17)] {
            let texel = level0.texels[face * (RESOLUTION * RESOLUTION) as usize + (y * RESOLUTION + x) as usize];
            let e = relative_error(rgb(texel), radiance(cube_direction(face, x, y, RESOLUTION)));
            assert!(e < 0.01, "radiance face {face} texel ({x}, {y}): error {e}");
        }
    }
    for level in 0..levels {
        let render::environment::CubeLevel { size, texels } = r.read_environment(true, level).expect("readback").expect("level");
        assert_eq!(size, RESOLUTION >> level);
        let roughness = level as f32 / (levels - 1) as f32;
        for face in 0..6 {
            for (x, y) in [(0, 0), (size / 2, size / 2), (size - 1, size / 3)] {
                let texel = texels[face * (size * size) as usize + (y * size + x) as usize];
                let want = if level == 0 {
                    radiance(cube_direction(face, x, y, size))
                } else {
                    prefiltered(cube_direction(face, x, y, size), roughness)
                };
                // 4 % and 0.01 (about 1 % of the map's mean): filtered importance sampling blurs
                // a little more than the exact integral where the map is darkest.
                let e = ((rgb(texel) - want).abs() / (0.04 * want + Vec3::splat(0.01))).max_element();
                worst = worst.max(e);
                assert!(e < 1.0, "level {level} (roughness {roughness}) face {face} texel ({x}, {y}): {:?} against {want:?}", rgb(texel));
            }
        }
    }
    println!("prefiltered levels: worst error {worst:.2} of the tolerance");
}

#[test]
fn a_missing_or_malformed_hdr_is_a_clear_error_and_the_sky_stands_in() {
    let missing = HdrImage::load("no/such/environment.hdr").expect_err("a missing file");
    assert!(matches!(missing, EnvironmentError::Load { .. }));
    assert!(missing.to_string().contains("no/such/environment.hdr"), "{missing}");

    let dir = std::env::temp_dir().join(format!("environment-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let garbage = dir.join("garbage.hdr");
    std::fs::write(&garbage, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\nnot pixels").unwrap();
    let malformed = HdrImage::load(&garbage).expect_err("a malformed file");
    assert!(malformed.to_string().contains("garbage.hdr"), "{malformed}");

    let (environment, error) = Environment::from_argument(garbage.to_str().unwrap());
    assert!(error.is_some(), "the error is reported");
    assert!(matches!(environment.source, EnvironmentSource::Sky), "the procedural sky stands in");
    assert!(matches!(Environment::from_argument("none").0.source, EnvironmentSource::None));
    assert!(matches!(Environment::from_argument("sky").0.source, EnvironmentSource::Sky));

    // The shared map loads, as an equirectangular image.
    let path = tests::shared_gltf_dir().join("../environments/royal_esplanade_1k.hdr");
    let map = HdrImage::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((map.width, map.height), (1024, 512));
    assert!(map.texels.iter().any(|t| t[0] > 1000.0), "its sun is far brighter than 1");
    std::fs::remove_dir_all(&dir).ok();
}

/// Radiance of the test cube map in direction `d`: each face its own colour, red growing across
/// the +Z face with its texel coordinate u (Vulkan's orientation: u along +X there).
fn cube_radiance(d: Vec3) -> Vec3 {
    const FACES: [Vec3; 6] = [
        Vec3::new(2.0, 0.2, 0.2),
        Vec3::new(0.2, 2.0, 0.2),
        Vec3::new(0.2, 0.2, 2.0),
        Vec3::new(1.0, 1.0, 0.2),
        Vec3::ZERO, // +Z: the gradient below
        Vec3::new(0.2, 1.0, 1.0),
    ];
    let a = d.abs();
    let face = if a.x >= a.y && a.x >= a.z {
        if d.x > 0.0 { 0 } else { 1 }
    } else if a.y >= a.z {
        if d.y > 0.0 { 2 } else { 3 }
    } else if d.z > 0.0 {
        4
    } else {
        5
    };
    if face == 4 { Vec3::new(2.0 * (d.x / d.z * 0.5 + 0.5), 0.5, 0.5) } else { FACES[face] }
}

#[test]
fn a_ktx2_cube_map_lights_the_sky_in_each_direction_and_bad_ones_are_clear_errors() {
    // A 32² cube in half floats, written with the ktx2 crate's serializers and loaded through
    // the `.ktx2` path; the sky, looking along each axis, shows its face's radiance (the +Z face
    // a gradient that checks its orientation).
    let face = 32u32;
    let mut data = Vec::new();
    for f in 0..6u32 {
        for y in 0..face {
            for x in 0..face {
                let st = Vec2::new((x as f32 + 0.5) / face as f32, (y as f32 + 0.5) / face as f32) * 2.0 - 1.0;
                let d = match f {
                    0 => Vec3::new(1.0, -st.y, -st.x),
                    1 => Vec3::new(-1.0, -st.y, st.x),
                    2 => Vec3::new(st.x, 1.0, st.y),
                    3 => Vec3::new(st.x, -1.0, -st.y),
                    4 => Vec3::new(st.x, -st.y, 1.0),
                    _ => Vec3::new(-st.x, -st.y, -1.0),
                };
                let c = cube_radiance(d);
                for v in [c.x, c.y, c.z, 1.0] {
                    data.extend_from_slice(&half::f16::from_f32(v).to_le_bytes());
                }
            }
        }
    }
    let dir = std::env::temp_dir().join(format!("ktx2-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cube.ktx2");
    std::fs::write(&path, tests::ktx2_file(ktx2::Format::R16G16B16A16_SFLOAT, face, face, 6, &data)).unwrap();
    let (environment, error) = Environment::from_argument(path.to_str().unwrap());
    assert!(error.is_none(), "{error:?}");
    let EnvironmentSource::Map(map) = &environment.source else { panic!("a map") };
    assert_eq!((map.width, map.height, map.projection), (face, 6 * face, engine::environment::Projection::CubeFaces));

    let (w, h) = (32u32, 32u32);
    let mut app = app(w, h, PipelineKind::Deferred, environment);
    for target in [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z, Vec3::new(0.0, 1.0, 0.01), Vec3::new(0.0, -1.0, 0.01)] {
        let camera = app.world.query_filtered::<Entity, With<Camera>>().iter(&app.world).collect::<Vec<_>>();
        for e in camera {
            app.world.despawn(e);
        }
        let view = View::spawn(&mut app, Vec3::ZERO, target, (w, h));
        app.update();
        let hdr = renderer(&mut app).read_hdr().expect("readback");
        // Pixels away from the face's edges, where bilinear filtering blends in the neighbour.
        for (px, py) in [(w / 2, h / 2), (w / 4, h / 2), (3 * w / 4, h / 2), (w / 2, h / 4)] {
            let d = view.ray(px, py);
            let want = cube_radiance(d);
            let got = rgb(hdr[(py * w + px) as usize]);
            assert!(relative_error(got, want) < 0.03, "looking at {target} pixel ({px},{py}): {got} vs {want}");
        }
    }
    assert_no_validation_errors(&mut app);

    // Wrong shapes and unreadable containers are errors that name the file.
    let four_faces = dir.join("four.ktx2");
    std::fs::write(&four_faces, tests::ktx2_file(ktx2::Format::R16G16B16A16_SFLOAT, face, face, 4, &data[..data.len() / 6 * 4])).unwrap();
    let square = dir.join("square.ktx2");
    std::fs::write(&square, tests::ktx2_file(ktx2::Format::R16G16B16A16_SFLOAT, face, face, 1, &data[..data.len() / 6])).unwrap();
    let ldr = dir.join("ldr.ktx2");
    std::fs::write(&ldr, tests::ktx2_file(ktx2::Format::R8G8B8A8_UNORM, face, face, 6, &data[..data.len() / 2])).unwrap();
    let garbage = dir.join("garbage.ktx2");
    std::fs::write(&garbage, b"not a ktx2 container at all").unwrap();
    for (file, says) in
        [(&four_faces, "4 faces"), (&square, "twice as wide"), (&ldr, "not a floating-point"), (&garbage, "not a valid KTX2")]
    {
        let e = HdrImage::load(file).expect_err("an error");
        let text = e.to_string();
        assert!(text.contains(file.file_name().unwrap().to_str().unwrap()) && text.contains(says), "{text}");
        assert!(matches!(Environment::from_argument(file.to_str().unwrap()).0.source, EnvironmentSource::Sky), "the sky stands in");
    }
    std::fs::remove_dir_all(&dir).ok();
}
