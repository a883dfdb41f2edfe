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

/// `brdf` (f · cos towards a direction) integrated by brute force over an area light's face as
/// `p` sees it, per unit radiance: `grid`² points spread evenly over the face by area, each
/// seen under dω = cos · dA / d². `point(u)` maps [0, 1)² onto the face of `area` that looks
/// along `facing`.
fn integrate_area(point: impl Fn(Vec2) -> Vec3, area: f32, facing: Vec3, p: Vec3, brdf: impl Fn(Vec3) -> Vec3, grid: u32) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for j in 0..grid {
        for i in 0..grid {
            let q = point(Vec2::new((i as f32 + 0.5) / grid as f32, (j as f32 + 0.5) / grid as f32));
            let to = q - p;
            let d2 = to.length_squared();
            let l = to / d2.sqrt();
            let cos_face = facing.dot(-l);
            if cos_face > 0.0 {
                sum += brdf(l) * cos_face / d2;
            }
        }
    }
    sum * (area / (grid * grid) as f32)
}

/// Rectangle and disk lights (issue 52, item 1) on a plane, against the BRDF integrated over
/// the light's face on the CPU. The rectangle stands upright with its lower part below the floor
/// (its polygon is clipped at the horizon of every point); the disk hangs tilted.
///
/// Tolerances, measured on lavapipe (96×72): the diffuse term is exact (the polygon's form
/// factor; the disk a 16-gon of its area) but takes Disney's retro-reflection factor towards the
/// light's mean direction: on the rough dielectric the relative error per pixel is 3.1 % on
/// average, 8.8 % at the 95th percentile for the rectangle (the horizon's cut), 1.2 % and 1.7 %
/// for the disk (2.7 % and 7.0 %, 0.19 % and 0.51 % with the LTC specular term's share in them).
/// The specular term is a fitted linearly transformed cosine (area_lights.glsl,
/// `render::lights::ltc`), which follows the GGX lobe closely seen from above and less so at
/// grazing views and in the lobe's tails: on the glossy metal 51 % and 85 % for the rectangle
/// (the representative point it replaced: 60 % and 147 %), 16 % and 59 % for the disk (20 % and
/// 49 %). Its bound catches a table read wrong or a lobe gone astray (docs/lights-and-shadows.md).
#[test]
fn area_lights_match_the_brdf_integrated_over_their_face() {
    let (w, h) = (96u32, 72u32);
    let mut app = gpu_app(w, h, RenderSettings { ambient: Vec3::ZERO, clear_color: [0.0; 4], ..Default::default() });
    let mesh = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 1.0));
    let materials = [(Vec3::new(0.8, 0.6, 0.4), 0.0, 0.9), (Vec3::new(0.9, 0.7, 0.4), 1.0, 0.5)];
    let handles: Vec<_> = materials
        .iter()
        .map(|&(b, m, r)| app.world.resource_mut::<Assets<Material>>().add(Material::from_color(b.extend(1.0), m, r)))
        .collect();
    let plane = app.world.spawn((MeshInstance { mesh, material: handles[0] }, Transform::default())).id();
    let eye = Vec3::new(0.0, 2.5, 3.5);
    let camera = Camera::default();
    app.world.spawn((camera, Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y)));
    let view = Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y).compute_matrix().inverse();
    let inv_view_proj = (camera.projection(w as f32 / h as f32) * view).inverse();
    let (color, luminance, range) = (Vec3::new(1.0, 0.9, 0.8), 2.0, 40.0);
    // Upright, facing +Z, from y = −0.2 to 0.8; and a disk tilted 40° from facing down.
    let rect_at = Transform::from_translation(Vec3::new(0.3, 0.3, -1.2)).looking_at(Vec3::new(0.3, 0.3, 0.0), Vec3::Y);
    let rect = RectLight { color, intensity: luminance, width: 1.6, height: 1.0, range: Some(range) };
    let disk_at = Transform::from_translation(Vec3::new(-0.4, 0.9, 0.2)).looking_at(Vec3::new(0.2, 0.0, 0.6), Vec3::Y);
    let disk = DiskLight { color, intensity: luminance, radius: 0.45, range: Some(range) };
    let light = app.world.spawn((rect, rect_at)).id();
    for (case, (shape, material)) in [("rect", 0), ("rect", 1), ("disk", 1), ("disk", 0)].into_iter().enumerate() {
        if case > 0 {
            app.world.entity_mut(plane).insert(MeshInstance { mesh, material: handles[material] });
        }
        if shape == "disk" {
            app.world.entity_mut(light).remove::<RectLight>().insert((disk, disk_at));
        }
        app.update();
        app.update();
        let hdr = renderer(&mut app).read_hdr().expect("readback");
        assert_no_validation_errors(&mut app);
        let at = if shape == "rect" { rect_at } else { disk_at };
        let (centre, facing) = (at.translation, at.rotation * Vec3::NEG_Z);
        let (x, y) = (at.rotation * Vec3::X, at.rotation * Vec3::Y);
        let (point, area): (Box<dyn Fn(Vec2) -> Vec3>, f32) = if shape == "rect" {
            (Box::new(move |u: Vec2| centre + x * (u.x - 0.5) * rect.width + y * (u.y - 0.5) * rect.height), rect.width * rect.height)
        } else {
            let r = disk.radius;
            (Box::new(move |u: Vec2| centre + r * u.x.sqrt() * (x * (2.0 * PI * u.y).cos() + y * (2.0 * PI * u.y).sin())), PI * r * r)
        };
        let (base, metallic, roughness) = materials[material];
        let (mut errors, mut lit) = (Vec::new(), 0.0f32);
        for py in (0..h).step_by(3) {
            for px in (0..w).step_by(3) {
                let ndc = Vec3::new((px as f32 + 0.5) / w as f32 * 2.0 - 1.0, 1.0 - (py as f32 + 0.5) / h as f32 * 2.0, 0.5);
                let dir = (inv_view_proj.project_point3(ndc) - eye).normalize();
                if dir.y >= -1e-3 {
                    continue;
                }
                let p = eye + dir * (-eye.y / dir.y);
                if p.x.abs() > 3.9 || p.z.abs() > 3.9 || facing.dot(p - centre) <= 0.0 {
                    continue; // off the plane, or behind the light
                }
                let brdf = |l: Vec3| brdf_cos(base, metallic, roughness, Vec3::Y, -dir, l);
                let expected =
                    integrate_area(&point, area, facing, p, brdf, 48) * color * luminance * window((centre - p).length_squared(), range);
                let got = Vec3::from_slice(&hdr[(py * w + px) as usize][..3]);
                let (e, g) = (expected.element_sum(), got.element_sum());
                lit = lit.max(e);
                if e > 0.01 {
                    errors.push((g - e).abs() / e);
                }
            }
        }
        errors.sort_by(f32::total_cmp);
        let mean = errors.iter().sum::<f32>() / errors.len() as f32;
        let p95 = errors[errors.len() * 95 / 100];
        eprintln!(
            "{shape} on material {material}: {} pixels, brightest {lit}; relative error mean {mean}, p95 {p95}, worst {}",
            errors.len(),
            errors.last().unwrap()
        );
        assert!(errors.len() > 150, "{shape}: the light lights the plane ({} pixels)", errors.len());
        let (mean_bound, p95_bound) = if metallic > 0.0 { (0.6, 1.0) } else { (0.05, 0.1) };
        assert!(mean <= mean_bound && p95 <= p95_bound, "{shape} on material {material}: relative error mean {mean}, p95 {p95}");
    }
}
