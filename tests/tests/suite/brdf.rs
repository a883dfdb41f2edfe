//! A lit plane rendered on the GPU against a CPU evaluation of the same BRDF (seed 000 §2.3),
//! pixel by pixel, in linear radiance read back from the HDR target.
//!
//! Tolerance: |gpu − cpu| ≤ 1.5 % of cpu + 0.002 per channel. The HDR target is RGBA16F
//! (relative precision 2⁻¹¹ ≈ 0.05 %); the rest covers the difference between the rasteriser's
//! interpolated world position and our exact ray–plane hit at the pixel centre.

use engine::prelude::*;
use plugins::RenderSettings;
use tests::{assert_no_validation_errors, gpu_app, renderer};

const PI: f32 = std::f32::consts::PI;

/// The Frostbite standard BRDF × cos, written independently of the shader.
fn brdf_cos(base: Vec3, metallic: f32, roughness: f32, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let n_dot_l = n.dot(l).clamp(0.0, 1.0);
    if n_dot_l <= 0.0 {
        return Vec3::ZERO;
    }
    let rough = roughness.clamp(0.045, 1.0);
    let alpha = rough * rough;
    let h = (v + l).normalize();
    let n_dot_v = (n.dot(v).abs() + 1e-5).min(1.0);
    let n_dot_h = n.dot(h).clamp(0.0, 1.0);
    let l_dot_h = l.dot(h).clamp(0.0, 1.0);
    let f0 = Vec3::splat(0.02).lerp(base, metallic);
    let fresnel = f0 + (Vec3::ONE - f0) * (1.0 - l_dot_h).powi(5);
    let a2 = alpha * alpha;
    let d = a2 / (PI * ((n_dot_h * n_dot_h) * (a2 - 1.0) + 1.0).powi(2));
    let lambda_v = n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
    let lambda_l = n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt();
    let vis = 0.5 / (lambda_v + lambda_l);
    let energy_bias = 0.5 * rough;
    let energy_factor = 1.0 + (1.0 / 1.51 - 1.0) * rough;
    let fd90 = energy_bias + 2.0 * l_dot_h * l_dot_h * rough;
    let scatter = |u: f32| 1.0 + (fd90 - 1.0) * (1.0 - u).powi(5);
    let fd = scatter(n_dot_l) * scatter(n_dot_v) * energy_factor / PI;
    (fresnel * (d * vis) + base * (1.0 - metallic) * fd) * n_dot_l
}

fn window(dist2: f32, range: f32) -> f32 {
    let f = dist2 / (range * range);
    let s = (1.0 - f * f).clamp(0.0, 1.0);
    s * s
}

fn check_plane(base: Vec3, metallic: f32, roughness: f32) {
    let (w, h) = (96u32, 72u32);
    let mut app = gpu_app(w, h, RenderSettings { ambient: Vec3::ZERO, clear_color: [0.0; 4], ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    let material = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(base.extend(1.0), metallic, roughness));
    app.world.spawn((MeshInstance { mesh, material }, Transform::default()));
    let light_pos = Vec3::new(0.4, 1.5, 0.2);
    let (light_color, intensity, range) = (Vec3::new(1.0, 0.9, 0.7), 3.0, 6.0);
    app.world
        .spawn((PointLight { color: light_color, intensity, range: Some(range), radius: 0.0 }, Transform::from_translation(light_pos)));
    let eye = Vec3::new(0.0, 2.5, 3.5);
    let camera = Camera::default();
    app.world.spawn((camera, Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y)));
    app.update();
    app.update();
    let hdr = renderer(&mut app).read_hdr().expect("readback");
    assert_no_validation_errors(&mut app);

    let view = Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y).compute_matrix().inverse();
    let inv_view_proj = (camera.projection(w as f32 / h as f32) * view).inverse();
    let (mut checked, mut worst) = (0, 0.0f32);
    for py in 0..h {
        for px in 0..w {
            let ndc_x = (px as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let ndc_y = 1.0 - (py as f32 + 0.5) / h as f32 * 2.0;
            let far = inv_view_proj.project_point3(Vec3::new(ndc_x, ndc_y, 0.5));
            let dir = (far - eye).normalize();
            if dir.y >= -1e-3 {
                continue;
            }
            let t = -eye.y / dir.y;
            let p = eye + dir * t;
            if p.x.abs() > 3.9 || p.z.abs() > 3.9 {
                continue; // off the plane or on its edge pixels
            }
            let to_light = light_pos - p;
            let d2 = to_light.length_squared();
            let expected = brdf_cos(base, metallic, roughness, Vec3::Y, -dir, to_light.normalize())
                * light_color
                * intensity
                * (window(d2, range) / d2.max(1e-4));
            let got = Vec3::from_slice(&hdr[(py * w + px) as usize][..3]);
            for c in 0..3 {
                let err = (got[c] - expected[c]).abs();
                let tol = 0.015 * expected[c] + 0.002;
                worst = worst.max(err / tol);
                assert!(err <= tol, "pixel ({px},{py}) channel {c}: gpu {} cpu {} (p = {p})", got[c], expected[c]);
            }
            checked += 1;
        }
    }
    assert!(checked > (w * h / 3) as usize, "the plane covers the view ({checked} pixels checked)");
    eprintln!("{checked} pixels within tolerance; worst error {:.0} % of tolerance", worst * 100.0);
}

#[test]
fn dielectric_plane_matches_the_cpu_brdf() {
    check_plane(Vec3::new(0.8, 0.5, 0.3), 0.0, 0.5);
}

#[test]
fn rough_metal_plane_matches_the_cpu_brdf() {
    check_plane(Vec3::new(0.9, 0.7, 0.4), 1.0, 0.3);
}

#[test]
fn smooth_plane_highlight_matches_the_cpu_brdf() {
    check_plane(Vec3::new(0.2, 0.3, 0.9), 0.0, 0.12);
}
