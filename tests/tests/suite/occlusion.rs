//! Ambient occlusion on lavapipe (`render::occlusion`), traced on both ray-tracing
//! tiers and in screen space: a 1 m box on open ground seen from above, under the flat ambient
//! colour. The occlusion view shows the factor shading multiplies ambient light by: about 1 on
//! open ground and on the box's top, well below 1 at the foot of its wall, rising with the
//! distance from it; the lit image is the ambient image × that factor; the frame reports the
//! method applied (screen space where rays cannot be traced); and switching it off gives 1.

use engine::prelude::*;
use plugins::{RenderSettings, RenderStats};
use render::{DebugView, OcclusionMethod, OcclusionSettings, PipelineKind, Tier};
use tests::{TopDownView, assert_no_validation_errors, gpu_app_at, renderer};

const SIZE: (u32, u32) = (160, 120);

/// The box's wall faces the camera at x = −1; the foot of the wall, a point 0.3 m away, open
/// ground 2.5 m away and the box's top.
const NEAR: Vec3 = Vec3::new(-0.96, 0.0, 0.0);
const MID: Vec3 = Vec3::new(-0.7, 0.0, 0.0);
const OPEN: Vec3 = Vec3::new(1.5, 0.0, 0.5);
const TOP: Vec3 = Vec3::new(-1.6, 1.0, 0.0);

fn scene(tier: Tier, pipeline: PipelineKind, method: OcclusionMethod) -> (App, TopDownView) {
    let settings = RenderSettings { pipeline, ambient: Vec3::splat(0.5), ..Default::default() };
    let mut app = gpu_app_at(SIZE.0, SIZE.1, settings, tier);
    app.world.resource_mut::<RenderSettings>().occlusion = OcclusionSettings { method, ..Default::default() };
    let mut meshes = app.world.resource_mut::<Assets<Mesh>>();
    let ground = meshes.add(shapes::plane(12.0, 12.0, 1, 1.0));
    let cube = meshes.add(shapes::cuboid(Vec3::ONE, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 1.0));
    app.world.spawn((MeshInstance { mesh: ground, material }, Transform::default()));
    app.world.spawn((MeshInstance { mesh: cube, material }, Transform::from_xyz(-1.5, 0.5, 0.0)));
    let view = TopDownView::new(4.0, SIZE);
    view.spawn(&mut app.world);
    (app, view)
}

/// Renders a frame in `debug_view` and returns the red channel at each of `points`.
fn read(app: &mut App, view: &TopDownView, debug_view: DebugView, points: &[Vec3]) -> Vec<f32> {
    app.world.resource_mut::<RenderSettings>().debug_view = debug_view;
    app.update();
    let image = renderer(app).read_hdr().unwrap();
    points
        .iter()
        .map(|&p| {
            let (px, py) = view.pixel_of(p);
            image[(py * SIZE.0 + px) as usize][0]
        })
        .collect()
}

#[test]
fn ambient_occlusion_darkens_the_foot_of_a_wall_and_nothing_in_the_open() {
    let cases = [
        (Tier::RayQuery, PipelineKind::Deferred, OcclusionMethod::RayTraced, OcclusionMethod::RayTraced),
        (Tier::RayTracingPipeline, PipelineKind::Forward, OcclusionMethod::RayTraced, OcclusionMethod::RayTraced),
        (Tier::RayQuery, PipelineKind::VisBuffer, OcclusionMethod::ScreenSpace, OcclusionMethod::ScreenSpace),
        // Without ray tracing, traced occlusion falls back to screen space.
        (Tier::NoRayTracing, PipelineKind::ForwardPlus, OcclusionMethod::RayTraced, OcclusionMethod::ScreenSpace),
    ];
    for (tier, pipeline, asked, applied) in cases {
        eprintln!("{tier:?} {pipeline:?} {asked:?}");
        let (mut app, view) = scene(tier, pipeline, asked);
        let points = [NEAR, MID, OPEN, TOP];
        let ao = read(&mut app, &view, DebugView::AmbientOcclusion, &points);
        let lit = read(&mut app, &view, DebugView::Lit, &points);
        plugins::finish_frames(&mut app.world);
        assert_eq!(app.world.resource::<RenderStats>().completed.back().map(|s| s.occlusion), Some(applied));
        app.world.resource_mut::<RenderSettings>().occlusion.method = OcclusionMethod::Off;
        let unoccluded = read(&mut app, &view, DebugView::Lit, &points);
        let off = read(&mut app, &view, DebugView::AmbientOcclusion, &points);
        assert_no_validation_errors(&mut app);
        eprintln!("occlusion at the foot, 0.3 m away, in the open, on top: {ao:?}");
        let [near, mid, open, top] = [ao[0], ao[1], ao[2], ao[3]];
        // Rays that hit nothing leave exactly 1; the screen-space integral over 32 slice
        // directions a 4×4 block comes within a few per cent of it on a plane.
        let open_at_least = if applied == OcclusionMethod::RayTraced { 0.999 } else { 0.95 };
        assert!(open >= open_at_least && top >= open_at_least, "open ground and the box's top are open: {ao:?}");
        assert!(near < 0.8, "the foot of the wall is occluded: {ao:?}");
        assert!(mid > near + 0.05 && mid < open, "occlusion fades with the distance from the wall: {ao:?}");
        for i in 0..points.len() {
            assert!(
                (lit[i] - unoccluded[i] * ao[i]).abs() < 2e-3 * unoccluded[i].max(1.0),
                "ambient × occlusion at {}: {lit:?} {unoccluded:?}",
                points[i]
            );
        }
        assert!(off.iter().all(|&o| o == 1.0), "switched off: {off:?}");
    }
}
