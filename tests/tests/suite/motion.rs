//! Motion vectors (`render/src/motion`) on lavapipe against a CPU reference. A box on the ground
//! moves while the camera moves too; every pixel's motion is checked against the projection, by
//! the previous and the current (unjittered) view, of the point the pixel shows (rebuilt from
//! the depth target with the jittered projection the frame was drawn with), moved back by the
//! box's own motion where it is the box. Then a frame in which nothing moved has no motion and
//! draws no mover. Every pipeline (each writes depth in its own pass, which the movers' pass
//! must match exactly).
//!
//! Tolerance: 2e-4 UV at most (a thirtieth of a pixel at 160×120; measured 6e-5, the RGBA16F
//! image's rounding), and the view depths within 0.2 %.

use engine::prelude::*;
use plugins::{RenderMirror, RenderSettings, RenderStats};
use render::{AntiAliasing, PipelineKind};
use tests::{assert_no_validation_errors, gpu_app, renderer};

const SIZE: (u32, u32) = (160, 120);

/// What a pixel shows.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Class {
    Ground,
    Box,
    Sky,
    Other,
}

/// The point pixel (x, y) shows, homogeneous (w = 0 for the sky), from the depth target and the
/// jittered inverse view-projection of the frame that drew it.
fn point(inv_view_proj: Mat4, depth: f32, x: u32, y: u32) -> Vec4 {
    // The viewport is flipped: row 0 is NDC y = +1.
    let ndc = (Vec2::new((x as f32 + 0.5) / SIZE.0 as f32, (y as f32 + 0.5) / SIZE.1 as f32) * 2.0 - 1.0) * Vec2::new(1.0, -1.0);
    inv_view_proj * Vec4::new(ndc.x, ndc.y, depth, 1.0)
}

fn project(view_proj: Mat4, p: Vec4) -> Vec2 {
    let c = view_proj * p;
    Vec2::new(c.x, c.y) / c.w
}

/// UV motion from NDC positions now and before (v grows downwards, with the rows).
fn uv_motion(now: Vec2, before: Vec2) -> Vec2 {
    (now - before) * Vec2::new(0.5, -0.5)
}

fn camera_at(app: &mut App, eye: Vec3) {
    let mut q = app.world.query_filtered::<&mut Transform, With<Camera>>();
    *q.single_mut(&mut app.world).unwrap() = Transform::from_translation(eye).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y);
}

fn motion_follows_the_camera_and_the_mover(pipeline: PipelineKind) {
    let settings = RenderSettings { pipeline, aa: AntiAliasing::Taa, ..Default::default() };
    let mut app = gpu_app(SIZE.0, SIZE.1, settings);
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.8));
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    let cube = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::ONE, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    let start = Vec3::new(0.0, 0.5, 0.0);
    let mover = app.world.spawn((MeshInstance { mesh: cube, material: grey }, Transform::from_translation(start))).id();
    app.world.spawn((Camera::default(), Transform::default()));
    camera_at(&mut app, Vec3::new(0.0, 2.0, 5.0));
    for _ in 0..3 {
        app.update();
    }
    let (prev_view_proj, prev_view) = {
        let c = app.world.resource::<RenderMirror>().0.camera();
        (c.view_proj, c.view)
    };

    // The box moves by `offset` and the camera moves too.
    let offset = Vec3::new(0.35, 0.0, 0.2);
    app.world.entity_mut(mover).insert(Transform::from_translation(start + offset));
    camera_at(&mut app, Vec3::new(0.4, 2.2, 4.8));
    app.update();
    assert_no_validation_errors(&mut app);
    assert_eq!(app.world.resource::<RenderStats>().last.motion_movers, 1, "{pipeline:?}: the box is the one mover");
    let motion = renderer(&mut app).read_motion().expect("read back the motion vectors");
    let depth = renderer(&mut app).read_depth().expect("read back depth");
    let (drawn, now) = {
        let m = &app.world.resource::<RenderMirror>().0;
        (m.gpu_camera(), *m.camera())
    };
    assert_ne!(drawn.jitter, Vec2::ZERO, "temporal anti-aliasing jitters the view");

    let (w, h) = SIZE;
    let class_at = |x: u32, y: u32| {
        let d = depth[(y * w + x) as usize];
        if d <= 0.0 {
            return Class::Sky;
        }
        let p = point(drawn.inv_view_proj, d, x, y);
        let p = p.truncate() / p.w;
        let local = p - (start + offset);
        if p.y.abs() < 2e-3 && local.abs().max_element() > 0.502 {
            Class::Ground
        } else if local.abs().max_element() < 0.502 {
            Class::Box
        } else {
            Class::Other
        }
    };
    let mut worst = [0.0f32; 3];
    let mut counted = [0usize; 3];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let class = class_at(x, y);
            if class == Class::Other
                || [(1, 0), (0, 1), (-1, 0), (0, -1)]
                    .iter()
                    .any(|&(dx, dy)| class_at((x as i32 + dx) as u32, (y as i32 + dy) as u32) != class)
            {
                continue; // edges: the pixel's surface is not certain
            }
            let i = (y * w + x) as usize;
            let p = point(drawn.inv_view_proj, depth[i], x, y);
            let before = if class == Class::Box { p - (offset * p.w).extend(0.0) } else { p };
            let expected = uv_motion(project(now.view_proj, p), project(prev_view_proj, before));
            let got = Vec2::new(motion[i][0], motion[i][1]);
            let k = class as usize;
            worst[k] = worst[k].max((got - expected).abs().max_element());
            counted[k] += 1;
            if class != Class::Sky {
                let depth_now = -(now.view * p).z / p.w;
                let depth_before = -(prev_view * before).z / before.w;
                assert!(
                    (motion[i][3] - depth_now).abs() <= 2e-3 * depth_now,
                    "{pipeline:?} ({x}, {y}): depth {} vs {depth_now}",
                    motion[i][3]
                );
                assert!(
                    (motion[i][2] - depth_before).abs() <= 2e-3 * depth_before,
                    "{pipeline:?} ({x}, {y}): previous depth {} vs {depth_before}",
                    motion[i][2]
                );
            }
        }
    }
    eprintln!(
        "{pipeline:?}: worst motion error (UV) ground {:.2e}, box {:.2e}, sky {:.2e}; pixels {counted:?}",
        worst[0], worst[1], worst[2]
    );
    assert!(counted.iter().all(|&n| n > 200), "{pipeline:?}: the ground, the box and the sky all show: {counted:?}");
    assert!(worst.iter().all(|&e| e <= 2e-4), "{pipeline:?}: motion within 2e-4 UV of the reference: {worst:?}");

    // Nothing moves: no motion, and no mover drawn.
    app.update();
    assert_no_validation_errors(&mut app);
    assert_eq!(app.world.resource::<RenderStats>().last.motion_movers, 0, "{pipeline:?}: nothing moved");
    let still = renderer(&mut app).read_motion().expect("read back the motion vectors");
    let most = still.iter().map(|m| m[0].abs().max(m[1].abs())).fold(0.0f32, f32::max);
    assert_eq!(most, 0.0, "{pipeline:?}: a still frame has no motion");
}

#[test]
fn motion_vectors_follow_the_camera_and_a_moving_box_in_every_pipeline() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        motion_follows_the_camera_and_the_mover(pipeline);
    }
}
