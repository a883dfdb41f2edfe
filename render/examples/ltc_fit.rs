//! Fits the linearly transformed cosines of our GGX specular lobe (Heitz, Dupuy, Hill and
//! Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed Cosines", §5) and
//! writes them, with the lobe's magnitude, as `render/src/lights/ltc/table.rs`, which the area
//! lights read through a built-in texture (`render::lights::ltc`, `shaders/include/area_lights.glsl`):
//!
//! ```text
//! cargo run --release -p render --example ltc_fit > render/src/lights/ltc/table.rs
//! ```
//!
//! For each perceptual roughness and view angle on a `LTC_SIZE`² grid, the lobe D·V·(n·l) of
//! `brdf.glsl` (GGX, height-correlated Smith, no Fresnel) is normalised to a distribution over
//! directions, and a matrix M found such that the clamped cosine transformed by M matches it: M
//! is the lobe's frame (its average direction as Z, the view plane's normal as Y) times
//! [[m00, 0, m02], [0, m11, 0], [0, 0, 1]], and (m00, m11, m02) minimise the L³ error of the two
//! distributions (Heitz et al.'s metric), estimated with 2 × 2,048 directions drawn from the GGX
//! normals and from the fitted cosine itself, by Nelder–Mead, from the roughest lobe (near the
//! cosine) to the smoothest, each start the previous fit. The table holds M's inverse in the
//! shading frame (x along the view's tangent, z the normal), normalised so that its last element
//! is 1: (a, b, c, d) of [[a, 0, b], [0, c, 0], [d, 0, 1]]; and the lobe's magnitude as the
//! split sum writes it, the scale and bias of F0 (∫ lobe · (1 − (1 − v·h)⁵) and ∫ lobe · (1 − v·h)⁵,
//! Schlick's Fresnel), as Heitz et al.'s second table carries it.
//!
//! Row `r` is perceptual roughness `r / (LTC_SIZE − 1)` (row 0, roughness 0, repeats row 1:
//! shading clamps roughness to 0.045, between rows 1 and 2), column `c` is √(1 − n·v) =
//! `c / (LTC_SIZE − 1)`. About 3 minutes (release).

use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Cells along each axis: perceptual roughness (rows) and √(1 − cos θ_v) (columns); the
/// renderer's `LTC_SIZE`.
const SIZE: usize = 32;
/// Directions drawn from each of the two distributions to estimate the error.
const SAMPLES: u32 = 2048;

fn d_ggx(n_dot_h: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let f = (n_dot_h * a2 - n_dot_h) * n_dot_h + 1.0;
    a2 / (PI * f * f)
}

fn v_smith(n_dot_v: f64, n_dot_l: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let lambda_v = n_dot_l * ((-n_dot_v * a2 + n_dot_v) * n_dot_v + a2).sqrt();
    let lambda_l = n_dot_v * ((-n_dot_l * a2 + n_dot_l) * n_dot_l + a2).sqrt();
    0.5 / (lambda_v + lambda_l)
}

/// The lobe D·V·(n·l) towards `l` for view `v` (normal +Z), unnormalised.
fn lobe(v: DVec3, l: DVec3, alpha: f64) -> f64 {
    if l.z <= 0.0 {
        return 0.0;
    }
    let h = (v + l).normalize();
    d_ggx(h.z.max(0.0), alpha) * v_smith(v.z.max(1e-5), l.z, alpha) * l.z
}

/// A direction drawn from the GGX normals (reflected about them) and its density.
fn sample_lobe(v: DVec3, alpha: f64, u: (f64, f64)) -> (DVec3, f64) {
    let phi = 2.0 * PI * u.0;
    let cos_t = ((1.0 - u.1) / (1.0 + (alpha * alpha - 1.0) * u.1)).sqrt();
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let h = DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
    let l = 2.0 * v.dot(h) * h - v;
    let pdf = d_ggx(cos_t, alpha) * cos_t / (4.0 * v.dot(h).abs().max(1e-9));
    (l, pdf)
}

/// The clamped cosine transformed by `m` (inverse `inv`, |det inv| `det`), towards `l`.
fn ltc_density(inv: &DMat3, det: f64, l: DVec3) -> f64 {
    let o = *inv * l;
    let len = o.length();
    let o = o / len;
    (o.z.max(0.0) / PI) * det / (len * len * len)
}

fn hammersley(i: u32, n: u32) -> (f64, f64) {
    ((i as f64 + 0.5) / n as f64, i.reverse_bits() as f64 / 4294967296.0)
}

/// A lobe to fit: its view, roughness, normalisation and frame.
struct Lobe {
    v: DVec3,
    alpha: f64,
    norm: f64,
    /// The lobe's integral weighted by Schlick's (1 − v·h)⁵.
    fresnel: f64,
    frame: DMat3,
}

impl Lobe {
    fn new(roughness: f64, cos_v: f64) -> Self {
        let alpha = roughness * roughness;
        let v = DVec3::new((1.0 - cos_v * cos_v).max(0.0).sqrt(), 0.0, cos_v);
        let (mut norm, mut fresnel, mut mean) = (0.0, 0.0, DVec3::ZERO);
        let n = 4096;
        for i in 0..n {
            let (l, pdf) = sample_lobe(v, alpha, hammersley(i, n));
            if l.z > 0.0 && pdf > 0.0 {
                let w = lobe(v, l, alpha) / pdf;
                norm += w;
                fresnel += w * (1.0 - v.dot((v + l).normalize()).clamp(0.0, 1.0)).powi(5);
                mean += l * w;
            }
        }
        norm /= n as f64;
        fresnel /= n as f64;
        // The average direction lies in the view's plane (y = 0), over the horizon.
        let mut z = DVec3::new(mean.x, 0.0, mean.z.max(1e-4)).normalize();
        if !z.is_finite() {
            z = DVec3::Z;
        }
        let y = DVec3::Y;
        let x = y.cross(z);
        Lobe { v, alpha, norm, fresnel, frame: DMat3::from_cols(x, y, z) }
    }

    fn matrix(&self, p: [f64; 3]) -> DMat3 {
        self.frame * DMat3::from_cols(DVec3::new(p[0], 0.0, 0.0), DVec3::new(0.0, p[1], 0.0), DVec3::new(p[2], 0.0, 1.0))
    }

    /// The L³ error between the normalised lobe and the cosine transformed by the parameters.
    fn error(&self, p: [f64; 3]) -> f64 {
        if p[0] <= 1e-4 || p[1] <= 1e-4 {
            return f64::INFINITY;
        }
        let m = self.matrix(p);
        let inv = m.inverse();
        let det = inv.determinant().abs();
        if !det.is_finite() || det <= 0.0 {
            return f64::INFINITY;
        }
        let mut error = 0.0;
        for i in 0..SAMPLES {
            let u = hammersley(i, SAMPLES);
            // From the lobe.
            let (l, pdf_lobe) = sample_lobe(self.v, self.alpha, u);
            if l.z > 0.0 && pdf_lobe > 0.0 {
                let target = lobe(self.v, l, self.alpha) / self.norm;
                let fitted = ltc_density(&inv, det, l);
                error += (target - fitted).abs().powi(3) / (pdf_lobe + fitted);
            }
            // From the transformed cosine.
            let r = u.0.sqrt();
            let o = DVec3::new(r * (2.0 * PI * u.1).cos(), r * (2.0 * PI * u.1).sin(), (1.0 - u.0).max(0.0).sqrt());
            let l = (m * o).normalize();
            let fitted = ltc_density(&inv, det, l);
            let target = lobe(self.v, l, self.alpha) / self.norm;
            let pdf_lobe = if l.z > 0.0 {
                let h = (self.v + l).normalize();
                d_ggx(h.z.max(0.0), self.alpha) * h.z.max(0.0) / (4.0 * self.v.dot(h).abs().max(1e-9))
            } else {
                0.0
            };
            if fitted > 0.0 {
                error += (target - fitted).abs().powi(3) / (pdf_lobe + fitted);
            }
        }
        error / (2 * SAMPLES) as f64
    }
}

/// Nelder–Mead from `start` with steps `step`.
fn minimise(f: impl Fn([f64; 3]) -> f64, start: [f64; 3], step: f64) -> [f64; 3] {
    let mut simplex: Vec<([f64; 3], f64)> = (0..4)
        .map(|k| {
            let mut p = start;
            if k > 0 {
                p[k - 1] += step * p[k - 1].abs().max(0.1);
            }
            (p, f(p))
        })
        .collect();
    for _ in 0..400 {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (simplex[3].1 - simplex[0].1).abs() <= 1e-9 * simplex[0].1.abs().max(1e-12) {
            break;
        }
        let centre = [0, 1, 2].map(|c| (simplex[0].0[c] + simplex[1].0[c] + simplex[2].0[c]) / 3.0);
        let along = |t: f64| [0, 1, 2].map(|c| centre[c] + t * (simplex[3].0[c] - centre[c]));
        let reflected = along(-1.0);
        let fr = f(reflected);
        if fr < simplex[0].1 {
            let expanded = along(-2.0);
            let fe = f(expanded);
            simplex[3] = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < simplex[2].1 {
            simplex[3] = (reflected, fr);
        } else {
            let contracted = along(if fr < simplex[3].1 { -0.5 } else { 0.5 });
            let fc = f(contracted);
            if fc < simplex[3].1.min(fr) {
                simplex[3] = (contracted, fc);
            } else {
                let best = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    s.0 = [0, 1, 2].map(|c| best[c] + 0.5 * (s.0[c] - best[c]));
                    s.1 = f(s.0);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0].0
}

fn main() {
    let mut table = vec![[0.0f64; 6]; SIZE * SIZE];
    let mut worst: f64 = 0.0;
    for column in 0..SIZE {
        let u = column as f64 / (SIZE - 1) as f64;
        let cos_v = (1.0 - u * u).max(1e-3);
        let mut guess = [1.0, 1.0, 0.0];
        let mut last_alpha = 1.0;
        for row in (0..SIZE).rev() {
            // Row 0 (roughness 0, no lobe) repeats row 1: shading clamps roughness to 0.045
            // (`surface_brdf`), which falls between rows 1 and 2, so row 0 is never read.
            let roughness = row.max(1) as f64 / (SIZE - 1) as f64;
            let lobe = Lobe::new(roughness, cos_v);
            if row == SIZE - 1 {
                guess = [1.0, 1.0, 0.0];
            } else {
                // Narrower than the last: start from its shape scaled to this roughness.
                let scale = lobe.alpha / last_alpha;
                guess = [guess[0] * scale, guess[1] * scale, guess[2]];
            }
            let fit = minimise(|p| lobe.error(p), guess, 0.2);
            let fit = minimise(|p| lobe.error(p), fit, 0.05);
            guess = fit;
            last_alpha = lobe.alpha;
            worst = worst.max(lobe.error(fit));
            let inv = lobe.matrix(fit).inverse();
            let e = inv.z_axis.z;
            table[row * SIZE + column] =
                [inv.x_axis.x / e, inv.z_axis.x / e, inv.y_axis.y / e, inv.x_axis.z / e, lobe.norm - lobe.fresnel, lobe.fresnel];
        }
    }
    eprintln!("fitted {} cells; largest error {worst:.3e}", SIZE * SIZE);
    println!("//! Generated by `cargo run --release -p render --example ltc_fit` (`render/examples/ltc_fit.rs`");
    println!("//! says how): per perceptual roughness (rows) and √(1 − n·v) (columns), the inverse linearly");
    println!("//! transformed cosine of `brdf.glsl`'s GGX lobe, (a, b, c, d) of [[a, 0, b], [0, c, 0], [d, 0, 1]]");
    println!("//! in the shading frame, then the lobe's split-sum scale and bias of F0.");
    println!();
    println!("/// The fitted cells, row after row.");
    println!("#[rustfmt::skip]");
    println!("pub(super) static LTC_TABLE: [[f32; 6]; {}] = [", SIZE * SIZE);
    for m in &table {
        println!("    [{}],", m.map(|x| literal(x as f32)).join(", "));
    }
    println!("];");
}

/// `x` as a Rust `f32` literal: the shortest decimal that reads back as `x`, with a point.
fn literal(x: f32) -> String {
    let text = x.to_string();
    if text.contains('.') { text } else { format!("{text}.0") }
}
