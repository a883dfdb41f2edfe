//! Anti-aliasing on lavapipe: a scene of thin posts and slanted wires, displayed with each mode,
//! against a 4×4-supersampled render of the same scene (the mean of each 4×4 block of a render
//! at four times the size), in every pipeline.

#![forbid(unsafe_code)]

use engine::prelude::*;
use plugins::RenderSettings;
use render::{AntiAliasing, DebugView, DecalMethod, PipelineKind};
use tests::{assert_no_validation_errors, gpu_app, renderer};

const SIZE: (u32, u32) = (128, 96);

/// Pale posts (when `posts`) and slanted wires (flat albedo, so edges are the only detail)
/// against a dark sky: about 2.5-pixel posts and 1.5-pixel wires at 128×96.
fn posts_and_wires(w: u32, h: u32, pipeline: PipelineKind, aa: AntiAliasing, posts: bool) -> Vec<u8> {
    let settings = RenderSettings {
        pipeline,
        aa,
        debug_view: DebugView::Albedo,
        decal_method: DecalMethod::Off,
        clear_color: [0.02, 0.02, 0.03, 1.0],
        ..Default::default()
    };
    let mut app = gpu_app(w, h, settings);
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.9, 0.85, 0.7, 1.0), 0.0, 0.8));
    let post = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(0.12, 3.0, 0.12), 1.0));
    let wire = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(6.0, 0.08, 0.08), 1.0));
    for i in 0..if posts { 7 } else { 0 } {
        let x = -1.8 + i as f32 * 0.6;
        app.world.spawn((MeshInstance { mesh: post, material }, Transform::from_xyz(x, 0.0, -i as f32 * 0.2)));
    }
    for (i, angle) in [-0.35f32, -0.12, 0.08, 0.3].into_iter().enumerate() {
        let transform = Transform::from_xyz(0.0, -0.6 + i as f32 * 0.4, 0.3).with_rotation(Quat::from_rotation_z(angle));
        app.world.spawn((MeshInstance { mesh: wire, material }, transform));
    }
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
    app.update();
    assert_no_validation_errors(&mut app);
    renderer(&mut app).read_display().expect("the display image reads back")
}

/// The mean of each `factor`×`factor` block of an RGBA8 image `w` pixels wide, in [0, 1].
fn downsample(image: &[u8], w: u32, factor: u32) -> Vec<[f32; 3]> {
    let (ow, oh) = (w / factor, image.len() as u32 / 4 / w / factor);
    let mut out = vec![[0.0f32; 3]; (ow * oh) as usize];
    for y in 0..oh * factor {
        for x in 0..ow * factor {
            let at = ((y * w + x) * 4) as usize;
            let o = &mut out[((y / factor) * ow + x / factor) as usize];
            for c in 0..3 {
                o[c] += image[at + c] as f32 / 255.0 / (factor * factor) as f32;
            }
        }
    }
    out
}

/// Mean absolute error against the reference over the pixels where it is not flat (an edge is
/// within the block), and the largest difference where it is flat.
fn error(image: &[u8], reference: &[[f32; 3]], flat: &[bool]) -> (f32, f32) {
    let mine = downsample(image, SIZE.0, 1);
    let (mut sum, mut n, mut flat_max) = (0.0f32, 0usize, 0.0f32);
    for (i, (a, b)) in mine.iter().zip(reference).enumerate() {
        let d = (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0;
        if flat[i] {
            flat_max = flat_max.max(d);
        } else {
            sum += d;
            n += 1;
        }
    }
    (sum / n.max(1) as f32, flat_max)
}

/// The mean error at edges without and with FXAA in `pipeline` (posts or not), checking that
/// FXAA leaves flat areas as they are.
fn edge_errors(pipeline: PipelineKind, posts: bool) -> (f32, f32) {
    let big = posts_and_wires(SIZE.0 * 4, SIZE.1 * 4, pipeline, AntiAliasing::None, posts);
    let reference = downsample(&big, SIZE.0 * 4, 4);
    // Flat: the 4×4 block and its neighbours' blocks are all sky or all wire (no edge near).
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    let flat: Vec<bool> = (0..h * w)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = reference[i as usize];
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (nx, ny) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                    let n = reference[(ny * w + nx) as usize];
                    (0..3).all(|k| (n[k] - c[k]).abs() < 0.002)
                })
            })
        })
        .collect();
    let edges = flat.iter().filter(|f| !**f).count();
    assert!(edges > 600, "{pipeline:?}: the posts and wires make edges ({edges} pixels)");
    let (plain, plain_flat) = error(&posts_and_wires(SIZE.0, SIZE.1, pipeline, AntiAliasing::None, posts), &reference, &flat);
    let (fxaa, fxaa_flat) = error(&posts_and_wires(SIZE.0, SIZE.1, pipeline, AntiAliasing::Fxaa, posts), &reference, &flat);
    eprintln!(
        "{pipeline:?}, posts {posts}: mean error at edges, none {plain:.4}, FXAA {fxaa:.4} ({:.2}x); flat areas max {plain_flat:.4} / {fxaa_flat:.4}",
        plain / fxaa
    );
    assert!(fxaa_flat <= plain_flat + 0.01, "{pipeline:?}: FXAA leaves flat areas alone: {plain_flat} / {fxaa_flat}");
    (plain, fxaa)
}

#[test]
fn fxaa_brings_slanted_wires_and_posts_closer_to_the_supersampled_image_in_every_pipeline() {
    for pipeline in [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer] {
        // Slanted wires: the stair steps FXAA is made for.
        let (plain, fxaa) = edge_errors(pipeline, false);
        assert!(fxaa <= plain * 0.8, "{pipeline:?}: FXAA reduces the error along slanted wires by 20 %: none {plain}, FXAA {fxaa}");
        // With upright posts: their edges are straight columns with no steps to find, which
        // FXAA leaves as they are, so the gain over the whole image is smaller.
        let (plain, fxaa) = edge_errors(pipeline, true);
        assert!(fxaa <= plain * 0.93, "{pipeline:?}: FXAA reduces the error with posts by 7 %: none {plain}, FXAA {fxaa}");
    }
}
