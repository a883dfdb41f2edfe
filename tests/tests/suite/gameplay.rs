//! The first-person game in the courtyard, played by scripts: shots land where independent ray
//! casts against the known geometry say (and show in the rendered image), the player follows the
//! floor and stops at walls, footprints alternate, keep their spacing and expire on time, the
//! decal cap recycles the oldest first, the BVH agrees with brute force, and bad scripts are
//! reported by line.
//!
//! Everything but the two GPU tests runs on the ECS alone (`tests::ecs_app`: the render plugin
//! without a renderer, 64×64, a fixed 16 ms frame). Times are counted in frames, never measured.

use std::f32::consts::FRAC_PI_6;

use engine::prelude::*;
use plugins::decal::DecalLifetime;
use plugins::{RenderMirror, RenderSettings};
use render::DebugView;
use sandbox::game::{
    BulletHole, DecalCap, Foot, Footprint, GameDecal, GamePlugin, GameSettings, GameStats, PlayerController, SceneRaycaster, Script,
    ScriptPlayer, SpawnOrder, setup_game, teleport,
};
use sandbox::scatter::SplitMix64;
use sandbox::scene::spawn_courtyard;
use tests::{assert_no_validation_errors, ecs_app, gpu_app, renderer};

/// The courtyard's walls are 0.8 m thick, centred 20 m from the middle: the inner face of the
/// north wall (the one at −Z) is the plane z = −19.6 (see `sandbox::scene`).
const NORTH_WALL_Z: f32 = -19.6;

/// An ECS-only app with the courtyard and the game, the courtyard's camera as the player.
fn game_app(settings: GameSettings, cap: DecalCap) -> (App, Entity) {
    let mut app = ecs_app();
    app.insert_resource(settings).insert_resource(cap);
    app.add_plugins(GamePlugin);
    let courtyard = spawn_courtyard(&mut app.world);
    setup_game(&mut app.world, courtyard.camera).expect("the courtyard camera becomes the player");
    (app, courtyard.camera)
}

fn dt(app: &App) -> f32 {
    app.world.resource::<Time>().fixed_step().expect("tests run at a fixed step").as_secs_f32()
}

/// Loads `text` into a script player and runs frames until it has played, calling `each` after
/// every frame.
fn play(app: &mut App, text: &str, mut each: impl FnMut(&mut App)) {
    let script = Script::parse(text).expect("a valid script");
    let frames = script.frames_at(dt(app)).unwrap();
    app.insert_resource(ScriptPlayer::new(script));
    for _ in 0..frames {
        app.update();
        each(app);
    }
    assert!(app.world.resource::<ScriptPlayer>().is_finished());
}

fn eye(app: &App, player: Entity) -> Vec3 {
    app.world.get::<Transform>(player).unwrap().translation
}

/// The ray through the normalised screen point `uv` of the player's camera, computed here from
/// the camera's view-projection matrix (not with the game's `screen_ray`).
fn camera_ray(app: &App, player: Entity, uv: Vec2) -> (Vec3, Vec3) {
    let (w, h) = app.world.resource::<RenderSettings>().size;
    let camera = app.world.get::<Camera>(player).unwrap();
    let transform = app.world.get::<Transform>(player).unwrap();
    let view_proj = camera.projection(w as f32 / h as f32) * transform.compute_matrix().inverse();
    let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let far_point = view_proj.inverse().project_point3(ndc.extend(0.5));
    (transform.translation, (far_point - transform.translation).normalize())
}

/// Where a ray meets the plane `normal · p = offset` (ahead of the origin).
fn plane_hit((origin, dir): (Vec3, Vec3), normal: Vec3, offset: f32) -> Vec3 {
    let t = (offset - normal.dot(origin)) / normal.dot(dir);
    assert!(t > 0.0, "the plane is behind the camera");
    origin + dir * t
}

/// Bullet holes in spawn order.
fn bullet_holes(app: &mut App) -> Vec<(Entity, Transform)> {
    let order: Vec<Entity> = app.world.resource::<SpawnOrder<GameDecal>>().iter().collect();
    order.into_iter().filter(|&e| app.world.get::<BulletHole>(e).is_some()).map(|e| (e, *app.world.get::<Transform>(e).unwrap())).collect()
}

#[test]
fn scripted_shots_land_where_the_ray_meets_the_ground_and_the_wall() {
    let (mut app, player) = game_app(GameSettings::default(), DecalCap::default());
    let ground_shots = [Vec2::new(0.5, 0.5), Vec2::new(0.3, 0.7), Vec2::new(0.75, 0.6), Vec2::new(0.5, 0.95)];
    let wall_shots = [Vec2::new(0.5, 0.5), Vec2::new(0.6, 0.35), Vec2::new(0.2, 0.8)];

    // Standing west of the fountain, looking north and 30° down at open ground.
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 8.0), Vec3::new(0.0, -FRAC_PI_6.tan(), -1.0)).unwrap();
    app.update();
    let script: String = ground_shots.iter().map(|p| format!("shoot {} {}\n", p.x, p.y)).collect();
    let mut expected = Vec::new();
    // The player does not move, so the camera at each click is the camera now.
    for &uv in &ground_shots {
        expected.push((plane_hit(camera_ray(&app, player, uv), Vec3::Y, 0.0), Vec3::Y));
    }
    play(&mut app, &script, |_| {});

    // Facing the north wall from 4.6 m, between two doorways.
    teleport(&mut app.world, player, Vec3::new(-9.5, 0.0, -15.0), Vec3::NEG_Z).unwrap();
    app.update();
    for &uv in &wall_shots {
        expected.push((plane_hit(camera_ray(&app, player, uv), Vec3::Z, NORTH_WALL_Z), Vec3::Z));
    }
    let script: String = wall_shots.iter().map(|p| format!("shoot {} {}\n", p.x, p.y)).collect();
    play(&mut app, &script, |_| {});
    app.update();

    let holes = bullet_holes(&mut app);
    assert_eq!(holes.len(), expected.len(), "one hole per shot");
    for ((_, transform), (point, normal)) in holes.iter().zip(&expected) {
        let error = transform.translation.distance(*point);
        assert!(error < 0.01, "hole at {} but the ray meets the surface at {point} ({error} m off)", transform.translation);
        let axis = transform.rotation * Vec3::Z;
        assert!(axis.dot(*normal) > 0.9999, "local +Z {axis} is not the surface normal {normal}");
        assert!((transform.scale.x - GameSettings::default().bullet_hole_size).abs() < 1e-6);
    }
    // Random rotations about the normal: no two ground holes share their local X.
    let xs: Vec<Vec3> = holes[..4].iter().map(|(_, t)| t.rotation * Vec3::X).collect();
    for i in 0..xs.len() {
        for j in i + 1..xs.len() {
            assert!(xs[i].dot(xs[j]) < 0.999, "holes {i} and {j} have the same rotation");
        }
    }
    let stats = *app.world.resource::<GameStats>();
    assert_eq!((stats.shots, stats.hits), (7, 7));
    // The render plugin extracted every hole.
    assert_eq!(app.world.resource::<RenderMirror>().0.decals.len(), 7);
}

/// The run command's demo (`assets/scripts/demo.txt`, what `scripts/run.sh` plays without a
/// display) parses, ends, and plays what it says: every shot hits the scene, one light drops,
/// the walk leaves footprints. On the ECS alone, where no fox walks: the demo's `aim` finds no
/// character, so its three shots at the fox go to the middle of the view and land on the ground
/// ahead (the sandbox's own run shows them on the fox). The sandbox test of the run command
/// plays a shorter script on lavapipe.
#[test]
fn the_demo_script_parses_and_ends() {
    let text = include_str!("../../../assets/scripts/demo.txt");
    let script = Script::parse(text).expect("the demo parses");
    let shots = script.commands().iter().filter(|(_, c)| matches!(c, sandbox::game::script::Command::Shoot(_))).count() as u64;
    let (mut app, _) = game_app(GameSettings::default(), DecalCap::default());
    play(&mut app, text, |_| {});
    app.update();
    let stats = *app.world.resource::<GameStats>();
    assert_eq!((stats.shots, stats.hits), (shots, shots), "every shot of the demo hits the scene: {stats:?}");
    assert_eq!(stats.lights, 1, "the demo drops one light");
    assert!(stats.footprints > 0, "the demo's walk leaves footprints");
}

#[test]
fn shots_at_the_sky_spawn_nothing() {
    let (mut app, player) = game_app(GameSettings::default(), DecalCap::default());
    teleport(&mut app.world, player, Vec3::new(0.0, 0.0, 10.0), Vec3::new(0.0, 1.0, -0.2)).unwrap();
    play(&mut app, "shoot 0.5 0.1\n", |_| {});
    app.update();
    assert!(bullet_holes(&mut app).is_empty());
    let stats = *app.world.resource::<GameStats>();
    assert_eq!((stats.shots, stats.hits), (1, 0));
}

#[test]
fn the_player_walks_on_the_floor_and_stops_at_the_wall() {
    let (mut app, player) = game_app(GameSettings::default(), DecalCap::default());
    let controller = *app.world.get::<PlayerController>(player).unwrap();
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 0.0), Vec3::NEG_Z).unwrap();
    assert!((eye(&app, player).y - controller.eye_height).abs() < 1e-5, "teleport stands on the ground");

    // Three seconds forward along x = −8, clear of the crates and columns.
    let mut heights = Vec::new();
    play(&mut app, "walk forward 3\n", |app| heights.push(eye(app, player).y));
    let frames = Script::parse("walk forward 3").unwrap().frames_at(dt(&app)).unwrap();
    let walked = frames as f32 * dt(&app) * controller.speed;
    let at = eye(&app, player);
    assert!((at.z + walked).abs() < 1e-3 && (at.x + 8.0).abs() < 1e-4, "walked to {at}, expected z = {}", -walked);
    assert!(heights.iter().all(|y| (y - controller.eye_height).abs() < 1e-4), "eye height kept above the ground");

    // Then on into the north wall: stopped one radius short of it, not through.
    let mut closest = f32::INFINITY;
    play(&mut app, "walk forward 5\n", |app| closest = closest.min(eye(app, player).z - NORTH_WALL_Z));
    let at = eye(&app, player);
    assert!((at.z - (NORTH_WALL_Z + controller.radius)).abs() < 1e-3, "stopped at {at}");
    assert!(closest >= controller.radius - 1e-3, "came within {closest} m of the wall");
    assert!((at.x + 8.0).abs() < 1e-3 && (at.y - controller.eye_height).abs() < 1e-4);

    // Turning right (east) and walking on slides along the wall.
    play(&mut app, "turn 90\nwalk forward 0.5\n", |_| {});
    let slid = eye(&app, player);
    assert!(slid.x > at.x + 1.0 && (slid.z - at.z).abs() < 1e-3, "{slid}");
}

#[test]
fn footprints_alternate_and_keep_their_spacing() {
    let settings = GameSettings::default();
    let (mut app, player) = game_app(settings.clone(), DecalCap::default());
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 0.0), Vec3::NEG_Z).unwrap();
    play(&mut app, "walk forward 2\n", |_| {});
    let walked = eye(&app, player).z.abs();
    let order: Vec<Entity> = app.world.resource::<SpawnOrder<GameDecal>>().iter().collect();
    assert_eq!(order.len(), (walked / settings.stride).floor() as usize, "one print per {} m over {walked} m", settings.stride);

    for (i, &print) in order.iter().enumerate() {
        let foot = app.world.get::<Footprint>(print).expect("only footprints were spawned").foot;
        let transform = *app.world.get::<Transform>(print).unwrap();
        let position = transform.translation;
        assert_eq!(foot, if i % 2 == 0 { Foot::Left } else { Foot::Right }, "print {i}");
        // Walking along −Z, right is +X; prints every stride from the start.
        let side = if foot == Foot::Right { 1.0 } else { -1.0 };
        assert!((position.x - (-8.0 + side * settings.foot_offset)).abs() < 1e-3, "print {i} at {position}");
        assert!((position.z + settings.stride * (i + 1) as f32).abs() < 1e-3, "print {i} at {position}");
        assert!(position.y.abs() < 1e-4, "print {i} on the ground");
        assert!((transform.rotation * Vec3::Z - Vec3::Y).length() < 1e-4, "projects down");
        assert!((transform.rotation * Vec3::Y - Vec3::NEG_Z).length() < 1e-4, "toe along the walk");
        let life = app.world.get::<DecalLifetime>(print).unwrap();
        assert_eq!((life.seconds, life.fade_out), (settings.footprint_lifetime, settings.footprint_fade));
    }
    assert_eq!(app.world.resource::<GameStats>().footprints, order.len() as u64);
}

#[test]
fn footprints_fade_and_despawn_after_their_lifetime() {
    let settings = GameSettings { footprint_lifetime: 1.0, footprint_fade: 0.5, ..Default::default() };
    let (mut app, player) = game_app(settings.clone(), DecalCap::default());
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 0.0), Vec3::NEG_Z).unwrap();
    let step = dt(&app);
    let lifetime_frames = (settings.footprint_lifetime / step).ceil() as u64;
    let fade_frames = (settings.footprint_fade / step).ceil() as u64;

    // Walk until the first print appears, then stand still.
    let mut first = None;
    let mut frame = 0u64;
    play(&mut app, "walk forward 0.3\n", |app| {
        frame += 1;
        if first.is_none() {
            first = app.world.query_filtered::<Entity, With<Footprint>>().iter(&app.world).next().map(|e| (e, frame));
        }
    });
    let (print, born) = first.expect("0.9 m walked: one print at 0.7 m");
    let mut seen_fading = false;
    while app.world.get_entity(print).is_ok() {
        let age = frame - born; // frames (steps of scene time) since the print was spawned
        let opacity = tests::decal_opacity_in_mirror(&app, print).expect("a live print has a record");
        assert!(age < lifetime_frames, "alive after {age} frames of a {lifetime_frames}-frame life");
        if age + fade_frames < lifetime_frames {
            assert_eq!(opacity, 1.0, "not fading yet at frame {age}");
        } else if age + fade_frames > lifetime_frames {
            assert!(opacity > 0.0 && opacity < 1.0, "fading at frame {age}: {opacity}");
            seen_fading = true;
        }
        app.update();
        frame += 1;
    }
    assert_eq!(frame - born, lifetime_frames, "despawned in the first frame at which its life had run out");
    assert!(seen_fading);
    assert!(app.world.resource::<SpawnOrder<GameDecal>>().iter().all(|e| e != print), "left the cap's queue");
}

#[test]
fn the_decal_cap_recycles_the_oldest_first() {
    let cap = 10;
    let (mut app, player) = game_app(GameSettings::default(), DecalCap { max: cap });
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 8.0), Vec3::new(0.0, -1.0, -1.0)).unwrap();
    let shots = cap + 5;
    let script: String = (0..shots).map(|i| format!("shoot {} {}\n", 0.2 + 0.04 * i as f32, 0.5 + 0.02 * i as f32)).collect();
    // Each shot is one frame: note the hole that frame added (the newest in the queue).
    let mut order = Vec::new();
    play(&mut app, &script, |app| {
        order.extend(app.world.resource::<SpawnOrder<GameDecal>>().iter().last());
    });
    app.update();
    assert_eq!(order.len(), shots, "every shot hit the ground");
    for (i, &hole) in order.iter().enumerate() {
        assert_eq!(app.world.get_entity(hole).is_ok(), i >= 5, "hole {i}");
    }
    let live: Vec<Entity> = app.world.resource::<SpawnOrder<GameDecal>>().iter().collect();
    assert_eq!(live, order[5..], "the newest remain, in spawn order");
    assert_eq!(app.world.query::<&GameDecal>().iter(&app.world).count(), cap);
    assert_eq!(app.world.resource::<GameStats>().decals_recycled, 5);
    assert_eq!(app.world.resource::<RenderMirror>().0.decals.len(), cap);
}

#[test]
fn dropped_lights_are_capped_too() {
    let (mut app, player) = game_app(GameSettings::default(), DecalCap::default());
    app.insert_resource(sandbox::game::LightCap { max: 2 });
    teleport(&mut app.world, player, Vec3::new(-8.0, 0.0, 8.0), Vec3::new(0.0, -1.0, -1.0)).unwrap();
    let lamps = app.world.query::<&PointLight>().iter(&app.world).count();
    play(&mut app, "light\nlight\nwait 0.1\nlight\n", |_| {});
    app.update();
    let mut dropped = app.world.query_filtered::<(&PointLight, &Transform), With<sandbox::game::GameLight>>();
    let dropped: Vec<(PointLight, Transform)> = dropped.iter(&app.world).map(|(l, t)| (*l, *t)).collect();
    assert_eq!(dropped.len(), 2);
    for (light, transform) in &dropped {
        // Looking 45° down from 1.7 m: the ground 1.7 m ahead, the light 1 m above it.
        assert!((transform.translation - Vec3::new(-8.0, 1.0, 8.0 - 1.7)).length() < 0.01, "{}", transform.translation);
        assert_eq!(light.intensity, GameSettings::default().light_intensity);
        assert!((light.color.max_element() - 1.0).abs() < 1e-6);
    }
    assert_ne!(dropped[0].0.color, dropped[1].0.color);
    assert_eq!(app.world.query::<&PointLight>().iter(&app.world).count(), lamps + 2);
    assert_eq!(app.world.resource::<GameStats>().lights_recycled, 1);
}

/// The nearest hit over every triangle, in f64 (Möller–Trumbore, double-sided).
fn brute_force(triangles: &[[glam::DVec3; 3]], origin: glam::DVec3, dir: glam::DVec3) -> Option<f64> {
    let mut best: Option<f64> = None;
    for [a, b, c] in triangles {
        let (e1, e2) = (*b - *a, *c - *a);
        let p = dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-15 {
            continue;
        }
        let s = origin - *a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = dir.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    }
    best
}

#[test]
fn the_bvh_agrees_with_brute_force() {
    let mut app = App::new();
    spawn_courtyard(&mut app.world);
    let raycaster = SceneRaycaster::build(&mut app.world);
    let mut triangles = Vec::new();
    let mut instances = app.world.query::<(&MeshInstance, &GlobalTransform)>();
    let meshes = app.world.resource::<Assets<Mesh>>();
    for (instance, global) in instances.iter(&app.world) {
        let mesh = meshes.get(instance.mesh).unwrap();
        let m = global.compute_matrix().as_dmat4();
        for tri in mesh.indices.chunks_exact(3) {
            triangles.push([0, 1, 2].map(|k| m.transform_point3(Vec3::from(mesh.positions[tri[k] as usize]).as_dvec3())));
        }
    }
    assert_eq!(raycaster.triangle_count(), triangles.len(), "every courtyard triangle is solid");

    let mut rng = SplitMix64::new(42);
    let (mut hits, mut misses) = (0, 0);
    for i in 0..300 {
        let origin = Vec3::new(rng.range_f32(-21.0, 21.0), rng.range_f32(0.05, 7.0), rng.range_f32(-21.0, 21.0));
        // Uniform directions; every fourth ray aims roughly at the fountain.
        let dir = if i % 4 == 0 {
            (Vec3::new(rng.range_f32(-2.0, 2.0), rng.range_f32(0.0, 3.0), rng.range_f32(-2.0, 2.0)) - origin).normalize()
        } else {
            let (z, phi) = (rng.range_f32(-1.0, 1.0), rng.range_f32(0.0, std::f32::consts::TAU));
            let r = (1.0 - z * z).sqrt();
            Vec3::new(r * phi.cos(), z, r * phi.sin())
        };
        let expected = brute_force(&triangles, origin.as_dvec3(), dir.as_dvec3());
        let got = raycaster.cast(origin, dir, f32::INFINITY);
        match (got, expected) {
            (Some(hit), Some(t)) => {
                assert!((hit.t as f64 - t).abs() < 1e-4, "ray {i}: BVH t = {}, brute force t = {t}", hit.t);
                assert!((hit.point - (origin + dir * hit.t)).length() < 1e-4);
                assert!(hit.normal.dot(dir) <= 0.0, "ray {i}: the normal faces the ray");
                hits += 1;
            }
            (None, None) => misses += 1,
            (got, expected) => {
                panic!("ray {i} from {origin} along {dir}: BVH {got:?}, brute force {expected:?}")
            }
        }
    }
    assert!(hits > 150 && misses > 30, "{hits} hits, {misses} misses: both cases exercised");
}

#[test]
fn malformed_scripts_name_the_line() {
    let error = Script::parse("wait 0.5\nwalk forward 1\nshoot 0.5\n").unwrap_err();
    assert_eq!(error.line, 3);
    assert!(error.to_string().contains("line 3"), "{error}");
    assert!(error.message.contains("shoot"), "{error}");

    let error = Script::parse("# header\nwalk up 2\n").unwrap_err();
    assert_eq!((error.line, error.message.contains("`up`")), (2, true), "{error}");

    let dir = std::env::temp_dir().join(format!("gameplay-script-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.txt");
    std::fs::write(&path, "wait 1\nwait 2\nkey Q\n").unwrap();
    let message = format!("{:#}", Script::load(&path).unwrap_err());
    assert!(message.contains("bad.txt") && message.contains("line 3") && message.contains("unknown key `Q`"), "{message}");
    let missing = format!("{:#}", Script::load(&dir.join("missing.txt")).unwrap_err());
    assert!(missing.contains("missing.txt"), "{missing}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Mean albedo luma of the 3×3 pixels around (`x`, `y`).
fn albedo_luma(hdr: &[[f32; 4]], width: u32, x: u32, y: u32) -> f32 {
    let mut sum = 0.0;
    for dy in 0..3 {
        for dx in 0..3 {
            let p = hdr[((y + dy - 1) * width + x + dx - 1) as usize];
            sum += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        }
    }
    sum / 9.0
}

#[test]
fn a_scripted_shot_shows_in_the_image() {
    let (w, h) = (160, 120);
    let mut app = gpu_app(w, h, RenderSettings { debug_view: DebugView::Albedo, ..Default::default() });
    app.add_plugins(GamePlugin);
    let courtyard = spawn_courtyard(&mut app.world);
    setup_game(&mut app.world, courtyard.camera).unwrap();
    // Looking 60° down at open ground, 2 m away along the view.
    teleport(&mut app.world, courtyard.camera, Vec3::new(-8.0, 0.0, 8.0), Vec3::new(0.0, -3f32.sqrt(), -1.0)).unwrap();
    // Aim at the centre of pixel (56, 72), off the screen centre.
    let (px, py) = (56, 72);
    let uv = Vec2::new((px as f32 + 0.5) / w as f32, (py as f32 + 0.5) / h as f32);
    for _ in 0..2 {
        app.update();
    }
    let before = renderer(&mut app).read_hdr().unwrap();
    play(&mut app, &format!("shoot {} {}\n", uv.x, uv.y), |_| {});
    app.update();
    let after = renderer(&mut app).read_hdr().unwrap();
    assert_eq!(app.world.resource::<GameStats>().hits, 1);

    let (lum_before, lum_after) = (albedo_luma(&before, w, px, py), albedo_luma(&after, w, px, py));
    assert!(lum_before > 0.1, "the ground's albedo is visible there: {lum_before}");
    assert!(lum_after < 0.5 * lum_before, "the hole darkens the albedo at the aimed pixel: {lum_before} -> {lum_after}");
    // Far from the hole nothing changed.
    let (fx, fy) = (140, 20);
    assert!((albedo_luma(&before, w, fx, fy) - albedo_luma(&after, w, fx, fy)).abs() < 1e-3);
    assert_no_validation_errors(&mut app);
}

#[test]
fn a_headless_scripted_run_writes_the_screenshot_and_the_game_statistics() {
    let dir = std::env::temp_dir().join(format!("gameplay-run-{}", std::process::id()));
    let opts = sandbox::headless::HeadlessOptions {
        frames: 2,
        size: (96, 64),
        screenshot: Some(dir.join("shot.png")),
        stats: Some(dir.join("stats.jsonl")),
        ..Default::default()
    };
    let script = Script::parse("look -40\nshoot\nwalk forward 0.5\nlight\n").unwrap();
    let summary = sandbox::game::play::run_scripted(&opts, script.clone()).unwrap();
    assert!(summary.validation_errors.is_empty(), "{:?}", summary.validation_errors);
    assert_eq!((summary.game.shots, summary.game.hits, summary.game.lights), (1, 1, 1));
    assert_eq!(summary.game.footprints, 2, "1.5 m walked: prints at 0.7 and 1.4 m");

    let image = image::open(dir.join("shot.png")).unwrap();
    assert_eq!((image.width(), image.height()), (96, 64));
    let stats = std::fs::read_to_string(dir.join("stats.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = stats.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let dt = 1.0 / 60.0;
    assert_eq!(lines.len() as u64, script.frames_at(dt).unwrap() + 2, "one line per frame");
    let last = &lines.last().unwrap()["game"];
    assert_eq!(last["hits"], 1);
    assert_eq!(last["live_decals"], 3, "a bullet hole and two footprints");
    assert_eq!(last["live_lights"], 1);
    assert_eq!(lines.last().unwrap()["particles"]["spawned"], 40, "the shot's sparks (GameSettings::sparks)");
    assert!(last["script_line"].is_null());
    assert!(lines[0]["game"]["script_line"] == 1);
    std::fs::remove_dir_all(&dir).ok();
}
