//! A lit quad through the whole forward pipeline, built from plain data (no ECS).

use glam::{Mat4, Vec2, Vec3};
use render::scene::{DrawItem, GpuCamera, GpuInstance, GpuLight, GpuMaterial, GpuVertex, MeshData, SceneMirror};
use render::{FrameSettings, Renderer, RendererSettings};

fn quad() -> MeshData {
    let v = |x: f32, z: f32| GpuVertex { position: [x, 0.0, z], normal: [0.0, 1.0, 0.0], uv: [x, z], tangent: [1.0, 0.0, 0.0, 1.0] };
    MeshData { vertices: vec![v(-1.0, -1.0), v(-1.0, 1.0), v(1.0, 1.0), v(1.0, -1.0)], indices: vec![0, 1, 2, 0, 2, 3] }
}

#[test]
fn lit_quad_renders_and_quiet_frames_upload_nothing() {
    let (w, h) = (64, 48);
    let mut r = Renderer::new(&RendererSettings::default(), w, h).expect("renderer");
    assert!(r.validation_enabled(), "tests run with the validation layer");
    let mut m = SceneMirror::new();
    let mesh = m.add_mesh(quad());
    let mat = m.materials.insert(GpuMaterial::default());
    m.set_instance(
        None,
        GpuInstance::new(Mat4::from_scale(Vec3::splat(4.0)), mat, 1),
        DrawItem { mesh, alpha_mask: false, double_sided: false },
    );
    m.lights.insert(GpuLight::point(Vec3::new(0.0, 1.0, 0.0), Vec3::splat(5.0), 10.0));
    let view = Mat4::look_at_rh(Vec3::new(0.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(1.0, w as f32 / h as f32, 0.1);
    m.set_camera(GpuCamera {
        view,
        proj,
        view_proj: proj * view,
        inv_view_proj: (proj * view).inverse(),
        position: Vec3::new(0.0, 2.0, 3.0),
        exposure: 1.0,
        viewport_size: Vec2::new(w as f32, h as f32),
        inv_viewport_size: Vec2::new(1.0 / w as f32, 1.0 / h as f32),
        ..Default::default()
    });
    let first = r.render(&mut m, &FrameSettings::default()).expect("frame");
    assert!(first.counters.bytes_uploaded > 0);
    m.begin_frame();
    let quiet = r.render(&mut m, &FrameSettings::default()).expect("frame");
    assert_eq!(quiet.counters.bytes_uploaded, 0);
    let hdr = r.read_hdr().expect("readback");
    let errors = r.take_validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:#?}");
    let centre = hdr[(h / 2 * w + w / 2) as usize];
    assert!(centre[0] > 0.01, "centre pixel is lit: {centre:?}");
    let corner = hdr[0];
    let errors = r.take_validation_errors();
    assert!(errors.is_empty(), "validation errors: {errors:#?}");
    eprintln!("centre {centre:?} corner {corner:?} device {}", r.device_name());
}
