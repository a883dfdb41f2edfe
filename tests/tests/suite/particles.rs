//! GPU particles (`render/src/particles`, `plugins::particles`) on lavapipe: bursts land where
//! the CPU's integration of the same motion (`render::particles::step`) says, in every
//! pipeline; the pool's free list neither leaks nor overflows; the CPU's work does not grow
//! with the particles; a moving particle's motion vectors are the CPU's; validation stays
//! clean.
//!
//! Tolerances: a landed particle's dot within 1.5 pixels of the projected CPU landing point at
//! 160×120 (the dot is 8 cm wide, about 5 pixels; the contact is where the last step crosses
//! the floor's plane rebuilt from depth, which the CPU computes the same way from y = 0;
//! measured 0.13 to 0.54 pixels); a moving particle's motion within 2e-5 UV of the CPU's
//! projection of its step (measured 3e-6, the RGBA16F target's rounding of 0.0045).

use engine::prelude::*;
use plugins::particles::{Contact, ParticleEmitter};
use plugins::{RenderMirror, RenderSettings, RenderStats};
use render::PipelineKind;
use tests::{assert_no_validation_errors, gpu_app, gpu_app_at, gpu_app_with, renderer};

const SIZE: (u32, u32) = (160, 120);
const DT: f32 = 0.016;

/// A dark floor seen from above at an angle.
fn floor_scene(app: &mut App) {
    let dark = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.05, 0.05, 0.05, 1.0), 0.0, 0.9));
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: dark }, Transform::default()));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 3.0, 3.0).looking_at(Vec3::new(0.0, 0.0, 0.3), Vec3::Y)));
}

/// A burst of `count` particles from `at`, all launched along `velocity` (a cone of 0°), glowing
/// magenta, sticking where they land.
fn launcher(at: Vec3, velocity: Vec3, count: u32) -> (ParticleEmitter, Transform) {
    let speed = velocity.length();
    let emitter = ParticleEmitter {
        rate: 0.0,
        burst: count,
        lifetime: (5.0, 5.0),
        speed: (speed, speed),
        cone_angle: 0.0,
        size: (0.08, 0.08),
        color: (Vec4::new(4.0, 0.0, 4.0, 0.0), Vec4::new(4.0, 0.0, 4.0, 0.0)),
        contact: Contact::Stick,
        softness: 0.0,
        lit: 0.0,
        ..ParticleEmitter::default()
    };
    (emitter, Transform::from_translation(at).with_rotation(Quat::from_rotation_arc(Vec3::Y, velocity / speed)))
}

/// Where the CPU's integration of the same steps crosses y = 0.
fn cpu_landing(at: Vec3, velocity: Vec3) -> Vec3 {
    let (mut p, mut v) = (at, velocity);
    for _ in 0..1000 {
        let before = p;
        render::particles::step(&mut p, &mut v, Vec3::new(0.0, -9.81, 0.0), 0.0, DT);
        if p.y <= 0.0 {
            let t = before.y / (before.y - p.y);
            return before.lerp(p, t);
        }
    }
    panic!("never landed");
}

/// The centroid of the pixels where the particles' magenta shows over the dark floor.
fn magenta_centroids(hdr: &[[f32; 4]], near: &[Vec2]) -> Vec<Vec2> {
    near.iter()
        .map(|&c| {
            let (mut sum, mut weight) = (Vec2::ZERO, 0.0);
            for y in 0..SIZE.1 {
                for x in 0..SIZE.0 {
                    let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let [r, g, b, _] = hdr[(y * SIZE.0 + x) as usize];
                    let m = (r.min(b) - g).max(0.0);
                    if p.distance(c) < 8.0 && m > 0.2 {
                        sum += p * m;
                        weight += m;
                    }
                }
            }
            assert!(weight > 0.0, "no particle near pixel {c}");
            sum / weight
        })
        .collect()
}

#[test]
fn bursts_land_where_the_cpu_integration_says_in_every_pipeline_and_tier() {
    let launches = [
        (Vec3::new(-0.8, 0.6, 0.0), Vec3::new(1.2, 0.5, 0.3)),
        (Vec3::new(0.5, 0.4, -0.3), Vec3::new(0.0, 1.5, 0.9)),
        (Vec3::new(0.2, 0.8, 0.6), Vec3::new(-1.0, -0.5, 0.0)),
    ];
    // Each pipeline on another tier: collision with the depth buffer, ray queries, traced rays.
    let runs = [
        (PipelineKind::Forward, render::Tier::NoRayTracing),
        (PipelineKind::Deferred, render::Tier::RayQuery),
        (PipelineKind::VisBuffer, render::Tier::RayTracingPipeline),
    ];
    for (pipeline, tier) in runs {
        let mut app = gpu_app_at(SIZE.0, SIZE.1, RenderSettings { pipeline, ..Default::default() }, tier);
        floor_scene(&mut app);
        for &(at, velocity) in &launches {
            app.world.spawn(launcher(at, velocity, 4));
        }
        // The slowest lands after about 0.55 s: 40 frames leave it resting.
        for _ in 0..40 {
            app.update();
        }
        assert_no_validation_errors(&mut app);
        let counts = app.world.resource::<RenderStats>().last.particles;
        assert_eq!((counts.spawned, counts.landed, counts.alive, counts.dropped), (12, 12, 12, 0), "{pipeline:?}: {counts:?}");
        assert_eq!(counts.ray_traced, tier != render::Tier::NoRayTracing, "{tier:?}: how the particles collided");
        assert!(counts.measured_frame >= 36, "{pipeline:?}: counts come back two frames late: {counts:?}");
        let view_proj = app.world.resource::<RenderMirror>().0.camera().view_proj;
        let pixel = |p: Vec3| {
            let ndc = view_proj.project_point3(p);
            Vec2::new((ndc.x * 0.5 + 0.5) * SIZE.0 as f32, (0.5 - ndc.y * 0.5) * SIZE.1 as f32)
        };
        let expected: Vec<Vec2> = launches.iter().map(|&(at, v)| pixel(cpu_landing(at, v))).collect();
        let hdr = renderer(&mut app).read_hdr().expect("read back the image");
        let found = magenta_centroids(&hdr, &expected);
        for (e, f) in expected.iter().zip(&found) {
            assert!(e.distance(*f) < 1.5, "{pipeline:?}: landed at pixel {f}, the CPU says {e}");
        }
    }
}

#[test]
fn the_pool_drops_what_does_not_fit_and_frees_what_dies() {
    let renderer_settings = render::RendererSettings { particle_capacity: 256, ..Default::default() };
    let mut app = gpu_app_with(128, 96, RenderSettings::default(), &renderer_settings);
    floor_scene(&mut app);
    let short = ParticleEmitter { rate: 0.0, burst: 1000, lifetime: (0.05, 0.05), contact: Contact::None, ..ParticleEmitter::default() };
    let emitter = app.world.spawn((short.clone(), Transform::from_xyz(0.0, 1.0, 0.0))).id();
    for _ in 0..8 {
        app.update();
    }
    let counts = app.world.resource::<RenderStats>().last.particles;
    assert_eq!((counts.spawned, counts.dropped, counts.alive, counts.capacity), (256, 744, 0, 256), "{counts:?}");
    // Every slot came back: a second burst fills the pool again, dropping the same share.
    app.world.entity_mut(emitter).insert(short.clone());
    app.update();
    // Particles are lit from the light tiles' lists wherever they float: a frame that draws them
    // culls lights without the tiles' depth masks.
    plugins::finish_frames(&mut app.world);
    let masked = app.world.resource::<RenderStats>().completed.back().expect("a finished frame").depth_mask;
    assert!(!masked, "no depth mask while particles are drawn");
    for _ in 0..7 {
        app.update();
    }
    let counts = app.world.resource::<RenderStats>().last.particles;
    assert_eq!((counts.spawned, counts.dropped), (512, 1488), "{counts:?}");
    // Despawned and its particles dead: the frame records no particle pass.
    app.world.despawn(emitter);
    for _ in 0..4 {
        app.update();
    }
    plugins::finish_frames(&mut app.world);
    let last = app.world.resource::<RenderStats>().completed.back().expect("a finished frame");
    assert!(last.gpu.iter().all(|(name, _)| !name.starts_with("particles")), "no particle pass once none can live");
    assert!(last.depth_mask, "the depth mask is back once no particle can live");
    assert_no_validation_errors(&mut app);
}

#[test]
fn the_cpu_does_nothing_per_particle() {
    let mut app = gpu_app(128, 96, RenderSettings::default());
    floor_scene(&mut app);
    let (mut emitter, transform) = launcher(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.3, 1.0, 0.0), 1);
    let e = app.world.spawn((emitter.clone(), transform)).id();
    app.update();
    app.update();
    // Each burst is the emitter inserted again: the same record, another count.
    let mut frame_with = |app: &mut App, count: u32| {
        emitter.burst = count;
        app.world.entity_mut(e).insert(emitter.clone());
        app.update();
        app.world.resource::<RenderStats>().last
    };
    let (few, many) = (frame_with(&mut app, 10), frame_with(&mut app, 20_000));
    assert_eq!(few.bytes_uploaded, many.bytes_uploaded, "the same job, whatever its count");
    assert_eq!(few.command_words, many.command_words, "the same commands");
    assert_no_validation_errors(&mut app);
}

#[test]
fn a_moving_particle_writes_its_own_motion_vectors() {
    let settings = RenderSettings { aa: render::AntiAliasing::Taa, ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    floor_scene(&mut app);
    let start = Vec3::new(-0.6, 1.0, 0.0);
    let velocity = Vec3::new(1.5, 0.0, 0.0);
    let (mut emitter, transform) = launcher(start, velocity, 1);
    (emitter.acceleration, emitter.contact, emitter.size) = (Vec3::ZERO, Contact::None, (0.6, 0.6));
    app.world.spawn((emitter, transform));
    let frames = 12;
    for _ in 0..frames {
        app.update();
    }
    assert_no_validation_errors(&mut app);
    let motion = renderer(&mut app).read_motion().expect("read back the motion vectors");
    let camera = *app.world.resource::<RenderMirror>().0.camera();
    // The CPU's particle now (a step a frame, the first in the frame it was born) and a frame ago.
    let now = start + velocity * DT * frames as f32;
    let project = |m: Mat4, p: Vec3| m.project_point3(p).truncate();
    let expected = (project(camera.motion_view_proj, now) - project(camera.prev_view_proj, now - velocity * DT)) * Vec2::new(0.5, -0.5);
    let ndc = project(camera.motion_view_proj, now);
    let pixel = |ndc: Vec2| (((ndc.x * 0.5 + 0.5) * SIZE.0 as f32) as u32, ((0.5 - ndc.y * 0.5) * SIZE.1 as f32) as u32);
    let (x, y) = pixel(ndc);
    let [mx, my, _, _] = motion[(y * SIZE.0 + x) as usize];
    assert!(expected.length() > 2e-3, "the particle moves on screen: {expected}");
    assert!((Vec2::new(mx, my) - expected).length() < 2e-5, "motion {mx}, {my} at the particle, the CPU says {expected}");
    // The static floor far from it keeps the camera's (zero) motion.
    let (fx, fy) = pixel(project(camera.motion_view_proj, Vec3::new(0.0, 0.0, 1.5)));
    let [fx_m, fy_m, _, _] = motion[(fy * SIZE.0 + fx) as usize];
    assert!(Vec2::new(fx_m, fy_m).length() < 1e-5, "the floor does not move: {fx_m}, {fy_m}");
}

/// Particles dropped onto a box behind the camera: on the ray-tracing tiers they stop on it (the
/// scene's structure holds it), then show there once the camera turns to it; without ray
/// tracing they fall through what the depth buffer does not show.
#[test]
fn particles_land_on_what_is_off_screen_on_the_ray_tracing_tiers() {
    for tier in [render::Tier::RayQuery, render::Tier::RayTracingPipeline, render::Tier::NoRayTracing] {
        let mut app = gpu_app_at(SIZE.0, SIZE.1, RenderSettings::default(), tier);
        floor_scene(&mut app);
        let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.3, 0.3, 0.3, 1.0), 0.0, 0.9));
        let cube = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::ONE, 1.0));
        // Behind the camera (at z = 3, looking towards −z).
        let top = Vec3::new(0.0, 1.0, 6.0);
        app.world.spawn((MeshInstance { mesh: cube, material: grey }, Transform::from_translation(top - Vec3::Y * 0.5)));
        app.world.spawn((DirectionalLight::default(), Transform::default().looking_at(Vec3::new(0.3, -1.0, -0.2), Vec3::Z)));
        app.world.spawn(launcher(top + Vec3::Y * 0.8, Vec3::new(0.0, -1.0, 0.0), 4));
        for _ in 0..30 {
            app.update();
        }
        let counts = app.world.resource::<RenderStats>().last.particles;
        if tier == render::Tier::NoRayTracing {
            assert_eq!((counts.landed, counts.ray_traced), (0, false), "{tier:?}: the depth buffer does not hold the box: {counts:?}");
            assert_no_validation_errors(&mut app);
            continue;
        }
        assert_eq!((counts.landed, counts.alive, counts.ray_traced), (4, 4, true), "{tier:?}: {counts:?}");
        // Turned to the box: the particles sit on its top.
        let mut q = app.world.query_filtered::<&mut Transform, With<Camera>>();
        *q.single_mut(&mut app.world).unwrap() = Transform::from_xyz(0.0, 2.5, 9.0).looking_at(top, Vec3::Y);
        for _ in 0..2 {
            app.update();
        }
        assert_no_validation_errors(&mut app);
        let view_proj = app.world.resource::<RenderMirror>().0.camera().view_proj;
        let ndc = view_proj.project_point3(top);
        let expected = Vec2::new((ndc.x * 0.5 + 0.5) * SIZE.0 as f32, (0.5 - ndc.y * 0.5) * SIZE.1 as f32);
        let hdr = renderer(&mut app).read_hdr().expect("read back the image");
        let found = magenta_centroids(&hdr, &[expected])[0];
        assert!(expected.distance(found) < 1.5, "{tier:?}: on the box at pixel {found}, its top's centre is at {expected}");
    }
}

/// An emitter's sprite follows its image: when the image goes, the emitter falls back to the
/// soft dot rather than sampling a freed bindless slot (extraction alone, no GPU).
#[test]
fn an_emitter_lets_go_of_a_removed_sprite() {
    let mut app = tests::ecs_app();
    let sprite = app.world.resource_mut::<Assets<Image>>().add(Image::solid([255, 200, 100, 255], ColorSpace::Srgb));
    let emitter = app.world.spawn((ParticleEmitter { texture: Some(sprite), ..ParticleEmitter::default() }, Transform::default())).id();
    app.update();
    let record_texture = |app: &App| {
        let slot = app.world.resource::<plugins::MirrorSlots>().emitter(emitter).expect("mirrored");
        app.world.resource::<RenderMirror>().0.emitters.record(slot).expect("live").texture
    };
    let uploaded = app.world.resource::<plugins::MirrorSlots>().texture(sprite).expect("uploaded");
    assert_eq!(record_texture(&app), uploaded);
    app.world.resource_mut::<Assets<Image>>().remove(sprite);
    app.update();
    assert_eq!(record_texture(&app), render::layout::TEXTURE_WHITE, "slot {uploaded} was freed with its image");
}

/// Dark pixels (below a third of the floor's brightness) near `at`, and their centroid.
fn dark_near(hdr: &[[f32; 4]], at: Vec2, floor: f32) -> (usize, Vec2) {
    let (mut n, mut sum) = (0, Vec2::ZERO);
    for y in 0..SIZE.1 {
        for x in 0..SIZE.0 {
            let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let [r, g, b, _] = hdr[(y * SIZE.0 + x) as usize];
            if p.distance(at) < 10.0 && (r + g + b) / 3.0 < floor / 3.0 {
                n += 1;
                sum += p;
            }
        }
    }
    (n, if n > 0 { sum / n as f32 } else { Vec2::NAN })
}

/// The last frame's image, the brightness of the floor at its left edge's middle, and where a
/// world point shows in it (pixels).
fn floor_image(app: &mut App) -> (Vec<[f32; 4]>, f32, impl Fn(Vec3) -> Vec2 + use<>) {
    let view_proj = app.world.resource::<RenderMirror>().0.camera().view_proj;
    let pixel = move |p: Vec3| {
        let ndc = view_proj.project_point3(p);
        Vec2::new((ndc.x * 0.5 + 0.5) * SIZE.0 as f32, (0.5 - ndc.y * 0.5) * SIZE.1 as f32)
    };
    let hdr = renderer(app).read_hdr().expect("read back the image");
    let [r, g, b, _] = hdr[(SIZE.1 / 2 * SIZE.0 + 4) as usize];
    (hdr, (r + g + b) / 3.0, pixel)
}

/// A light grey floor seen from above at an angle, for landing particles to leave decals on;
/// returns the black decal material they leave.
fn soot_floor(app: &mut App) -> Handle<plugins::decal::DecalMaterial> {
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.8, 0.8, 0.8, 1.0), 0.0, 0.9));
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 3.0, 3.0).looking_at(Vec3::new(0.0, 0.0, 0.3), Vec3::Y)));
    let soot = plugins::decal::DecalMaterial { base_color: Some(Vec4::new(0.0, 0.0, 0.0, 1.0)), ..Default::default() };
    app.world.resource_mut::<Assets<plugins::decal::DecalMaterial>>().add(soot)
}

/// Particles that die where they land leave a decal each, written by the GPU, at the contact
/// point, in every decal method (each on the tier and in a pipeline it runs in), the frame they
/// land; the decals fade out and expire with their lifetime.
#[test]
fn landing_particles_leave_decals_in_every_decal_method() {
    use plugins::particles::LeftDecal;
    use render::{DecalMethod, Tier};
    let runs = [
        (PipelineKind::Forward, DecalMethod::RayQuery, Tier::RayQuery),
        (PipelineKind::VisBuffer, DecalMethod::RayPipeline, Tier::RayTracingPipeline),
        (PipelineKind::Forward, DecalMethod::Clustered, Tier::NoRayTracing),
        (PipelineKind::Deferred, DecalMethod::DeferredDecals, Tier::RayQuery),
    ];
    let spots = [Vec3::new(-0.8, 0.0, 0.2), Vec3::new(0.4, 0.0, -0.3), Vec3::new(0.9, 0.0, 0.7)];
    for (pipeline, decal_method, tier) in runs {
        let settings = RenderSettings { pipeline, decal_method, ambient: Vec3::splat(0.6), ..Default::default() };
        let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
        let soot = soot_floor(&mut app);
        for &spot in &spots {
            let (mut emitter, transform) = launcher(spot + Vec3::Y * 0.5, Vec3::new(0.0, -2.0, 0.0), 1);
            emitter.contact = Contact::Die;
            emitter.lifetime = (0.3, 0.3);
            emitter.leaves = Some(LeftDecal { material: soot, size: 0.25, depth: 0.2, lifetime: 0.5, fade: 0.1 });
            app.world.spawn((emitter, transform));
        }
        // They land after about 0.18 s (11 frames of 16 ms). Ray-query decals switch to
        // clustered ones after two frames (the ring's structures built over no decal yet), and
        // back once every particle is gone (0.3 s): the structures, not followed while nothing
        // traced them, must catch up the frame ray-query decals are on again.
        let late_tracing = decal_method == DecalMethod::RayQuery;
        for frame in 0..if late_tracing { 22 } else { 16 } {
            if late_tracing && (frame == 2 || frame == 21) {
                let method = if frame == 2 { DecalMethod::Clustered } else { decal_method };
                app.world.resource_mut::<RenderSettings>().decal_method = method;
            }
            app.update();
        }
        assert_no_validation_errors(&mut app);
        let counts = app.world.resource::<RenderStats>().last.particles;
        assert_eq!((counts.landed, counts.decals_born, counts.alive), (3, 3, 0), "{decal_method:?}: {counts:?}");
        let (hdr, floor, pixel) = floor_image(&mut app);
        for &spot in &spots {
            let (n, centre) = dark_near(&hdr, pixel(spot), floor);
            assert!(n >= 4, "{decal_method:?}: no decal at {spot} (pixel {})", pixel(spot));
            assert!(centre.distance(pixel(spot)) < 1.5, "{decal_method:?}: the decal at {centre}, the particle landed at {}", pixel(spot));
        }
        // A game can read them back (to save them): one per landing, where it landed, as left.
        let left = plugins::particles::read_left_decals(&mut app.world).expect("read back the left decals");
        let now = app.world.resource::<engine::time::Time>().elapsed_secs();
        assert_eq!(left.len(), 3, "{decal_method:?}: {left:?}");
        for &spot in &spots {
            let d =
                left.iter().find(|d| d.position.distance(spot) < 0.02).unwrap_or_else(|| panic!("no decal read back at {spot}: {left:?}"));
            assert!(d.normal.dot(Vec3::Y) > 0.999 && (d.size - 0.25).abs() < 1e-4 && (d.depth - 0.2).abs() < 1e-4, "{d:?}");
            assert_eq!(d.material, Some(soot));
            let left_for = d.expires.expect("a decal with a lifetime expires") - now;
            assert!(left_for > 0.0 && left_for <= 0.5, "{decal_method:?}: {left_for} s of its 0.5 s left");
        }
        // 0.5 s after they landed, the decals are gone.
        for _ in 0..30 {
            app.update();
        }
        let hdr = renderer(&mut app).read_hdr().expect("read back the image");
        for &spot in &spots {
            assert_eq!(dark_near(&hdr, pixel(spot), floor).0, 0, "{decal_method:?}: the decal at {spot} outlived its lifetime");
        }
        assert_no_validation_errors(&mut app);
    }
}

/// The decal ring wraps: with room for two, three landings leave three decals of which the
/// newest two show (the oldest overwritten) and read back, oldest first. The pool was made
/// before any emitter left decals: its ring's places still start empty (binned nowhere).
#[test]
fn the_decal_ring_keeps_the_newest() {
    use plugins::particles::LeftDecal;
    let renderer_settings = render::RendererSettings {
        particle_decals: 2,
        device: render::DeviceSettings { max_tier: render::Tier::NoRayTracing, ..Default::default() },
        ..Default::default()
    };
    let settings = RenderSettings { decal_method: render::DecalMethod::Clustered, ambient: Vec3::splat(0.6), ..Default::default() };
    let mut app = gpu_app_with(SIZE.0, SIZE.1, settings, &renderer_settings);
    let soot = soot_floor(&mut app);
    // A plain emitter first: the pool is made without a ring in use.
    let (plain, at) = launcher(Vec3::new(-2.0, 0.5, 0.0), Vec3::Y, 1);
    app.world.spawn((plain, at));
    for _ in 0..3 {
        app.update();
    }
    let spots = [Vec3::new(-0.8, 0.0, 0.2), Vec3::new(0.4, 0.0, -0.3), Vec3::new(0.9, 0.0, 0.7)];
    for (i, &spot) in spots.iter().enumerate() {
        // One after the other, a frame apart: the first lands first.
        let (mut emitter, transform) = launcher(spot + Vec3::Y * (0.3 + 0.05 * i as f32), Vec3::new(0.0, -2.0, 0.0), 1);
        emitter.contact = Contact::Die;
        emitter.leaves = Some(LeftDecal { material: soot, size: 0.25, depth: 0.2, lifetime: 0.0, fade: 0.0 });
        app.world.spawn((emitter, transform));
    }
    // Before any lands (they take about 0.15 s), the ring is binned but holds no decal.
    for _ in 0..6 {
        app.update();
    }
    let clusters = app.world.resource::<RenderStats>().last.clusters;
    assert!(clusters.measured_frame != u64::MAX && clusters.entries == 0, "empty places binned: {clusters:?}");
    for _ in 0..10 {
        app.update();
    }
    assert_no_validation_errors(&mut app);
    let counts = app.world.resource::<RenderStats>().last.particles;
    assert_eq!((counts.landed, counts.decals_born), (3, 3), "{counts:?}");
    let left = plugins::particles::read_left_decals(&mut app.world).expect("read back the left decals");
    let at: Vec<Vec3> = left.iter().map(|d| d.position).collect();
    assert!(at.len() == 2 && at[0].distance(spots[1]) < 0.02 && at[1].distance(spots[2]) < 0.02, "the newest two, oldest first: {at:?}");
    assert!(left.iter().all(|d| d.expires.is_none()), "a lifetime of 0 lasts until overwritten");
    let (hdr, floor, pixel) = floor_image(&mut app);
    let shown: Vec<bool> = spots.iter().map(|&s| dark_near(&hdr, pixel(s), floor).0 >= 4).collect();
    assert_eq!(shown, [false, true, true], "the oldest was overwritten");
}

/// The ring's structure is cut into segments of 256 places, each its own BLAS (a frame rebuilds
/// only those the ring filled): decals past the first segment are traced at their contact
/// points too, by ray queries and by the ray-tracing pipeline. 257 particles land first where
/// the camera does not see, then three in view take places 257 to 259. The filled first
/// segment is rebuilt while the second is refit, validation clean.
#[test]
fn decals_past_the_first_segment_of_the_ring_are_traced() {
    use plugins::particles::LeftDecal;
    use render::{DecalMethod, Tier};
    for (pipeline, decal_method, tier) in [
        (PipelineKind::Forward, DecalMethod::RayQuery, Tier::RayQuery),
        (PipelineKind::VisBuffer, DecalMethod::RayPipeline, Tier::RayTracingPipeline),
    ] {
        let device = render::DeviceSettings { max_tier: tier, ..Default::default() };
        let renderer_settings = render::RendererSettings { particle_decals: 512, device, ..Default::default() };
        let settings = RenderSettings { pipeline, decal_method, ambient: Vec3::splat(0.6), ..Default::default() };
        let mut app = gpu_app_with(SIZE.0, SIZE.1, settings, &renderer_settings);
        let soot = soot_floor(&mut app);
        let leaves = Some(LeftDecal { material: soot, size: 0.25, depth: 0.2, lifetime: 0.0, fade: 0.0 });
        // Behind the camera: the first segment's 256 places and one more.
        let (mut unseen, at) = launcher(Vec3::new(0.0, 0.3, 3.8), Vec3::new(0.0, -2.0, 0.0), 257);
        (unseen.contact, unseen.leaves) = (Contact::Die, leaves);
        app.world.spawn((unseen, at));
        for _ in 0..14 {
            app.update();
        }
        let spots = [Vec3::new(-0.8, 0.0, 0.2), Vec3::new(0.4, 0.0, -0.3), Vec3::new(0.9, 0.0, 0.7)];
        for &spot in &spots {
            let (mut emitter, transform) = launcher(spot + Vec3::Y * 0.3, Vec3::new(0.0, -2.0, 0.0), 1);
            (emitter.contact, emitter.leaves) = (Contact::Die, leaves);
            app.world.spawn((emitter, transform));
        }
        for _ in 0..14 {
            app.update();
        }
        assert_no_validation_errors(&mut app);
        let counts = app.world.resource::<RenderStats>().last.particles;
        assert_eq!(counts.decals_born, 260, "{decal_method:?}: {counts:?}");
        let (hdr, floor, pixel) = floor_image(&mut app);
        for &spot in &spots {
            let (n, centre) = dark_near(&hdr, pixel(spot), floor);
            assert!(n >= 4, "{decal_method:?}: no decal at {spot} (pixel {})", pixel(spot));
            assert!(centre.distance(pixel(spot)) < 1.5, "{decal_method:?}: the decal at {centre}, the particle landed at {}", pixel(spot));
        }
        // The first segment, filled, waits at most 30 frames for its rebuild, in the same call
        // that refits the second: a frame both builds and refits.
        let mixed = (0..24).any(|_| {
            app.update();
            let c = app.world.resource::<RenderStats>().last;
            c.blas_builds > 0 && c.blas_updates > 0
        });
        assert!(mixed, "{decal_method:?}: no frame rebuilt the filled segment");
        assert_no_validation_errors(&mut app);
    }
}
