//! Built-in decal textures, generated procedurally and deterministically (integer hash and value
//! noise from [`crate::scene::textures`], no random-number crate), so every run and every machine
//! produces the same bytes.
//!
//! Five sets: a [`bullet_hole`], a muddy [`footprint`], a [`puddle`], scattered autumn
//! [`leaves`] and a glowing [`sigil`]. Each is a [`DecalTextureSet`] of engine [`Image`]s with
//! full mip chains: an sRGB albedo whose alpha is the decal's coverage, an optional linear
//! tangent-space normal map (glTF convention: +Y is image-up, i.e. decreasing V, encoded
//! `n · 0.5 + 0.5`, alpha = the same coverage) and, for the puddle, a linear metallic-roughness
//! map (G = roughness, B = metallic = 0).
//!
//! Coverage is exactly zero on the outer texels of every image (a soft window multiplies it), so
//! decals never show the edges of their projection box. Texels without coverage carry a colour
//! continued from the shape's edge and a flat normal, so filtering and mipmapping do not bleed
//! dark fringes or bogus slopes into the shape.
//!
//! Heights (for the normal maps) are in UV units, i.e. in fractions of the decal's width, so the
//! slopes do not depend on the texture resolution.
//!
//! [`write_pngs`] writes level 0 of every image as PNG; the copies committed under
//! `assets/decals/` are checked against the generator byte for byte by the unit tests. After
//! changing the generator, regenerate them with the `gen_decal_textures` tool
//! (`sandbox/src/bin/gen_decal_textures.rs`):
//!
//! ```sh
//! cargo run -p sandbox --bin gen_decal_textures            # writes assets/decals/*.png
//! cargo run -p sandbox --bin gen_decal_textures -- out/dir  # or into another directory
//! ```

use bevy_ecs::world::World;
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use engine::asset::{Assets, Handle};
use engine::image::{ColorSpace, Image};
use glam::{Vec2, Vec3, Vec4};
use plugins::decal::DecalMaterial;

use crate::scene::textures::{fbm, hash, hash01, value_noise};

/// The images of one built-in decal.
#[derive(Clone, Debug, PartialEq)]
pub struct DecalTextureSet {
    /// Short identifier, also the PNG file prefix: `bullet_hole`, `footprint`, `puddle`,
    /// `leaves` or `sigil`.
    pub name: &'static str,
    /// sRGB albedo; alpha is the decal's coverage.
    pub albedo: Image,
    /// Linear tangent-space normal map (glTF convention), alpha = coverage.
    pub normal: Option<Image>,
    /// Linear metallic-roughness map: G = roughness, B = metallic.
    pub metallic_roughness: Option<Image>,
}

/// Name of the bullet-hole set.
pub const BULLET_HOLE: &str = "bullet_hole";
/// Name of the footprint set.
pub const FOOTPRINT: &str = "footprint";
/// Name of the puddle set.
pub const PUDDLE: &str = "puddle";
/// Name of the leaves set.
pub const LEAVES: &str = "leaves";
/// Name of the sigil set.
pub const SIGIL: &str = "sigil";

/// One generated texel before encoding.
#[derive(Clone, Copy, Debug)]
struct Texel {
    /// Linear albedo.
    color: Vec3,
    /// Coverage in [0, 1] (before the border window).
    alpha: f32,
    /// Height in UV units.
    height: f32,
    /// Roughness in [0, 1] (only used for sets with a metallic-roughness map).
    roughness: f32,
}

impl Texel {
    fn new(color: Vec3, alpha: f32, height: f32) -> Self {
        Texel { color, alpha, height, roughness: 1.0 }
    }
}

/// Which optional maps a set has.
#[derive(Clone, Copy)]
struct Maps {
    normal: bool,
    metallic_roughness: bool,
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn srgb_byte(linear: f32) -> u8 {
    let c = if linear.is_finite() { linear.clamp(0.0, 1.0) } else { 0.0 };
    let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

fn unorm_byte(v: f32) -> u8 {
    let c = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    (c * 255.0 + 0.5) as u8
}

/// Coverage multiplier: 0 on the outer texel ring, rising smoothly to 1 over 4 % of the size.
fn border_window(uv: Vec2, size: u32) -> f32 {
    let edge = uv.min(Vec2::ONE - uv).min_element();
    let texel = 1.0 / size as f32;
    smoothstep(texel, texel + 0.04, edge)
}

/// Renders a `size`² set from `sample(uv)` evaluated at texel centres.
fn render(name: &'static str, size: u32, maps: Maps, sample: impl Fn(Vec2) -> Texel) -> DecalTextureSet {
    let size = size.max(4);
    let n = size as usize;
    let mut texels = Vec::with_capacity(n * n);
    for y in 0..n {
        for x in 0..n {
            let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size as f32;
            let mut t = sample(uv);
            t.alpha = if t.alpha.is_finite() { t.alpha.clamp(0.0, 1.0) } else { 0.0 };
            t.alpha *= border_window(uv, size);
            if !t.height.is_finite() {
                t.height = 0.0;
            }
            texels.push(t);
        }
    }
    let alpha_bytes: Vec<u8> = texels.iter().map(|t| unorm_byte(t.alpha)).collect();

    let mut albedo = Vec::with_capacity(n * n * 4);
    for (t, &a) in texels.iter().zip(&alpha_bytes) {
        albedo.extend([srgb_byte(t.color.x), srgb_byte(t.color.y), srgb_byte(t.color.z), a]);
    }
    let image = |data: Vec<u8>, space: ColorSpace| {
        // The data is built for exactly size² texels, so this cannot fail; fall back to a
        // transparent texel rather than panicking all the same.
        Image::from_rgba8(size, size, data, space).unwrap_or_else(|_| Image::solid([0; 4], space))
    };

    let normal = maps.normal.then(|| {
        // Central differences with clamped borders; slopes in UV units (du = 1 / size per texel).
        let h = |x: isize, y: isize| {
            let cx = x.clamp(0, n as isize - 1) as usize;
            let cy = y.clamp(0, n as isize - 1) as usize;
            texels[cy * n + cx].height
        };
        let mut data = Vec::with_capacity(n * n * 4);
        for y in 0..n as isize {
            for x in 0..n as isize {
                let a = alpha_bytes[y as usize * n + x as usize];
                let v = if a == 0 {
                    Vec3::Z
                } else {
                    let scale = size as f32 * 0.5;
                    let dhdu = (h(x + 1, y) - h(x - 1, y)) * scale;
                    let dhdv = (h(x, y + 1) - h(x, y - 1)) * scale;
                    // +Y is image-up (decreasing V): n = (-dh/du, +dh/dv, 1).
                    Vec3::new(-dhdu, dhdv, 1.0).normalize_or(Vec3::Z)
                };
                let encode = |c: f32| unorm_byte(c * 0.5 + 0.5);
                data.extend([encode(v.x), encode(v.y), encode(v.z), a]);
            }
        }
        image(data, ColorSpace::Linear)
    });

    let metallic_roughness = maps.metallic_roughness.then(|| {
        let mut data = Vec::with_capacity(n * n * 4);
        for t in &texels {
            data.extend([0, unorm_byte(t.roughness), 0, 255]);
        }
        image(data, ColorSpace::Linear)
    });

    DecalTextureSet { name, albedo: image(albedo, ColorSpace::Srgb), normal, metallic_roughness }
}

/// Periodic 1D value noise of an angle (radians), `period` lattice cells per turn.
fn angular_noise(theta: f32, period: u32, seed: u32) -> f32 {
    value_noise(Vec2::new(theta.rem_euclid(TAU) / TAU, 0.37), period, seed)
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
    (p - a - ab * t).length()
}

/// Wraps an angle difference into (−π, π].
fn wrap_angle(a: f32) -> f32 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI { w + TAU } else { w }
}

/// A bullet hole: a burnt, nearly black crater in the middle, a chipped ring of exposed lighter
/// material, radial cracks and a sooty halo fading to nothing. 128² texels.
pub fn bullet_hole() -> DecalTextureSet {
    const SIZE: u32 = 128;
    // Cracks: (angle, length, seed) — lengths in units of the half width.
    let cracks: Vec<(f32, f32, u32)> = (0..6)
        .map(|i| {
            let angle = (i as f32 + 0.8 * hash01(i, 0, 101)) / 6.0 * TAU;
            let length = 0.48 + 0.3 * hash01(i, 1, 101);
            (angle, length, 200 + i)
        })
        .collect();
    render(BULLET_HOLE, SIZE, Maps { normal: true, metallic_roughness: false }, |uv| {
        let p = (uv - 0.5) * 2.0; // [-1, 1]², r = 1 at the edge midpoints
        let r = p.length();
        let theta = p.y.atan2(p.x);
        let hole = 0.15 + 0.05 * (angular_noise(theta, 9, 11) - 0.5);
        // Chipped ring: broad irregularity plus finer chips.
        let ring = 0.37 + 0.12 * (angular_noise(theta, 7, 12) - 0.5) + 0.07 * (angular_noise(theta, 23, 13) - 0.5);
        let grain = fbm(uv, 8, 14);

        // Cracks: wiggly radial lines, thinning and fading outwards (at least a texel wide so
        // they do not break up into dashes).
        let texel = 2.0 / SIZE as f32;
        let mut crack = 0.0f32;
        for &(angle, length, seed) in &cracks {
            if r < hole || r > length {
                continue;
            }
            let wiggle = 0.5 * (value_noise(Vec2::new(r * 0.9, 0.5), 5, seed) - 0.5)
                + 0.12 * (value_noise(Vec2::new(r * 3.0, 0.5), 8, seed + 50) - 0.5);
            let lateral = wrap_angle(theta - angle - wiggle).abs() * r; // in units of r
            let taper = 1.0 - r / length;
            let half_width = texel * (0.45 + 0.8 * taper);
            let line = 1.0 - smoothstep(half_width - texel * 0.5, half_width + texel * 0.5, lateral);
            crack = crack.max(line * smoothstep(0.0, 0.25, taper));
        }

        let in_hole = 1.0 - smoothstep(hole - texel, hole + texel, r);
        let in_ring = 1.0 - smoothstep(ring - texel, ring + texel, r);
        // Soot: dense near the ring, fading out by r ≈ 0.88.
        let soot = (1.0 - smoothstep(ring, 0.88, r)).powf(1.6) * (0.6 + 0.4 * grain);
        let coverage = in_ring.max(soot * 0.9).max(crack * (1.0 - smoothstep(0.7, 0.88, r)));

        // Colours (linear): exposed chipped material, burnt towards the hole, soot outside.
        let chipped = Vec3::new(0.3, 0.285, 0.26) * (0.7 + 0.6 * grain) * (0.8 + 0.2 * smoothstep(hole, ring, r));
        let burnt = Vec3::new(0.035, 0.028, 0.022);
        let black = Vec3::new(0.008, 0.006, 0.005);
        let burn = 1.0 - smoothstep(hole, hole + 0.22, r);
        let ring_color = chipped.lerp(burnt, burn * 0.9);
        let soot_color = Vec3::new(0.045, 0.04, 0.036) * (0.8 + 0.4 * grain);
        let mut color = soot_color.lerp(ring_color, in_ring);
        color = color.lerp(black, in_hole);
        color = color.lerp(Vec3::splat(0.02), crack * 0.85);

        // Height (UV units): a deep bowl in the hole, a cone up the chipped ring, a faint lip.
        let bowl = -0.05 * (1.0 - smoothstep(hole * 0.3, hole * 1.1, r));
        let cone = -0.035 * (1.0 - smoothstep(hole, ring, r));
        let lip = 0.004 * (-((r - ring) / 0.06).powi(2)).exp();
        let rough = 0.004 * grain * in_ring;
        let height = bowl + cone + lip + rough - 0.003 * crack;
        Texel::new(color, coverage, height)
    })
}

/// Polynomial smooth maximum of `a` and `b` over a blend width `k`.
fn smooth_max(a: f32, b: f32, k: f32) -> f32 {
    let h = (0.5 + 0.5 * (a - b) / k).clamp(0.0, 1.0);
    b + (a - b) * h + k * h * (1.0 - h)
}

/// Signed distance (UV units, negative inside) of an ellipse, approximated by scaling.
fn ellipse_sd(p: Vec2, centre: Vec2, radii: Vec2) -> f32 {
    let q = (p - centre) / radii;
    (q.length() - 1.0) * radii.min_element()
}

/// A muddy shoe-sole print of a right shoe, toe towards image-up (local +Y of the decal):
/// forefoot with chevron lugs and a rim, a separate heel with bars, darker compacted mud where
/// the lugs pressed, a slight depression in the normal map. 256² texels.
pub fn footprint() -> DecalTextureSet {
    const SIZE: u32 = 256;
    render(FOOTPRINT, SIZE, Maps { normal: true, metallic_roughness: false }, |uv| {
        let texel = 1.0 / SIZE as f32;
        let noise = fbm(uv, 8, 41);
        let edge_noise = 0.012 * (fbm(uv * 2.0, 8, 42) - 0.5);
        // Forefoot: rounded toe, widest at the ball, tapering towards the waist; its centre line
        // leans towards the big-toe side (image-left for a right shoe seen from above).
        let (toe, waist) = (0.055, 0.585);
        let t = ((uv.y - toe) / (waist - toe)).clamp(0.0, 1.0);
        let round = 1.0 - (1.0 - (t / 0.4).min(1.0)).powi(2);
        let half_width = 0.158 * round.max(0.0).sqrt() * (1.0 - 0.3 * smoothstep(0.4, 1.0, t));
        let centre = 0.5 - 0.035 * (1.0 - t) + 0.02 * t;
        // The forefoot ends on a slant (the outer side reaches further) with rounded corners.
        let end = waist - 0.015 + 0.025 * ((uv.x - centre) / 0.11).clamp(-1.5, 1.5);
        let fore = smooth_max(((uv.x - centre).abs() - half_width).max(toe - uv.y), uv.y - end, 0.04);
        let heel = ellipse_sd(uv, Vec2::new(0.52, 0.815), Vec2::new(0.118, 0.128)).max(0.695 - uv.y);
        let sole = fore.min(heel) + edge_noise;
        let inside = 1.0 - smoothstep(-texel, texel, sole);

        // Tread: a rim along the outline, chevron lugs in the forefoot, bars in the heel.
        let rim = 1.0 - smoothstep(0.012, 0.018, -sole);
        let lugs = if fore < heel {
            let chevron = (uv.y + 0.6 * (uv.x - 0.51).abs()) * 26.0;
            smoothstep(0.3, 0.4, (chevron.fract() - 0.5).abs())
        } else {
            let bars = uv.y * 30.0;
            smoothstep(0.28, 0.38, (bars.fract() - 0.5).abs())
        };
        let pressed = rim.max(lugs); // 1 where the sole touched the mud

        let mud = Vec3::new(0.085, 0.058, 0.035) * (0.75 + 0.5 * noise);
        let compacted = Vec3::new(0.05, 0.034, 0.021) * (0.85 + 0.3 * noise);
        let color = mud.lerp(compacted, pressed * inside);
        let coverage = inside * (0.78 + 0.2 * pressed) * (0.85 + 0.15 * noise);

        // Crumbs of mud around the print.
        let cell = (uv * 28.0).floor();
        let (cx, cy) = (cell.x as u32, cell.y as u32);
        let jitter = Vec2::new(hash01(cx, cy, 43), hash01(cx, cy, 44));
        let crumb_r = 0.004 + 0.008 * hash01(cx, cy, 45);
        let crumb_d = (uv - (cell + jitter) / 28.0).length();
        let near = smoothstep(0.06, 0.0, sole) * (hash01(cx, cy, 46) < 0.55) as u32 as f32;
        let crumb = near * (1.0 - smoothstep(crumb_r - texel, crumb_r + texel, crumb_d));
        let coverage = coverage.max(crumb * 0.9);

        // Depression: the print sinks in, lugs deeper, crumbs sit on top.
        let height = -0.006 * smoothstep(texel * 2.0, -0.02, sole) - 0.004 * pressed * inside + 0.002 * noise * inside + 0.003 * crumb;
        Texel::new(color, coverage, height)
    })
}

/// A puddle: an irregular blob of dark water with a soft edge, gentle ripples in the normal
/// map and a metallic-roughness map whose roughness is ~0.05 in the water, rising to 0.6 on the
/// damp rim. 256² texels.
pub fn puddle() -> DecalTextureSet {
    const SIZE: u32 = 256;
    // Rain-drop ripple sources: (centre, phase, amplitude, wavelength).
    let ripples: Vec<(Vec2, f32, f32, f32)> = (0..6)
        .map(|i| {
            let c = Vec2::new(0.25 + 0.5 * hash01(i, 0, 61), 0.25 + 0.5 * hash01(i, 1, 61));
            let wavelength = 0.025 + 0.02 * hash01(i, 4, 61);
            (c, TAU * hash01(i, 2, 61), 0.0005 + 0.0005 * hash01(i, 3, 61), wavelength)
        })
        .collect();
    render(PUDDLE, SIZE, Maps { normal: true, metallic_roughness: true }, |uv| {
        let p = uv - 0.5;
        let blob = p.length() / 0.37 + 0.45 * (fbm(uv, 3, 62) - 0.5) + 0.1 * (value_noise(uv, 6, 63) - 0.5);
        let coverage = 1.0 - smoothstep(0.82, 1.0, blob);
        let water = 1.0 - smoothstep(0.6, 0.95, blob);
        let silt = fbm(uv, 16, 64);
        let rim = Vec3::new(0.2, 0.18, 0.155) * (0.8 + 0.4 * silt);
        let deep = Vec3::new(0.1, 0.115, 0.135) * (0.9 + 0.2 * silt);
        let color = rim.lerp(deep, water);

        // Each drop's rings spread a few wavelengths, plus a faint wind swell.
        let mut height = 0.0015 * (value_noise(uv + Vec2::new(0.0, 0.3), 5, 65) - 0.5);
        for &(c, phase, amplitude, wavelength) in &ripples {
            let d = (uv - c).length() / wavelength;
            height += amplitude * (d * TAU + phase).sin() * (-d / 3.0).exp();
        }
        height *= water;
        let roughness = 0.05 + 0.55 * (1.0 - water);
        Texel { color, alpha: coverage, height, roughness }
    })
}

/// One leaf of [`leaves`]: placement and look.
struct Leaf {
    centre: Vec2,
    /// Unit vector along the midrib, from stem to tip.
    axis: Vec2,
    /// Half length in UV units.
    half_length: f32,
    /// Half width relative to the half length.
    width: f32,
    /// 0: smooth elliptic, 1: lobed (oak-like), 2: serrated.
    shape: u32,
    color: Vec3,
    seed: u32,
}

impl Leaf {
    /// Coverage (anti-aliased), vein intensity, height and local position (s along the midrib
    /// in [−1, 1], t across) at `uv`.
    fn sample(&self, uv: Vec2, texel: f32) -> (f32, f32, f32) {
        let d = uv - self.centre;
        let s = d.dot(self.axis) / self.half_length;
        let t = d.perp_dot(self.axis) / self.half_length;
        // Width profile: pointed tip, rounder base.
        let profile = |s: f32| {
            if s.abs() >= 1.0 {
                return 0.0;
            }
            let (a, b) = (0.9f32, 0.6f32);
            let peak = (b - a) / (a + b);
            let f = |s: f32| (1.0 - s).powf(a) * (1.0 + s).powf(b);
            f(s) / f(peak)
        };
        let mut w = self.width * profile(s);
        match self.shape {
            1 => w *= 0.7 + 0.3 * (s * PI * 2.5 + 0.6).cos().abs(),
            2 => w *= 1.0 - 0.08 * (s * 14.0).fract(),
            _ => {}
        }
        // UV units, positive inside; beyond the tip and base the blade ends.
        let inside_d = (w - t.abs() - (s.abs() - 1.0).max(0.0)) * self.half_length;
        let blade = smoothstep(-texel, texel, inside_d);
        // The stem sticks out behind the base.
        let stem_d = if (-1.3..=-0.9).contains(&s) { 0.018 - t.abs() } else { -1.0 };
        let stem = smoothstep(-texel, texel, stem_d * self.half_length);
        let coverage = blade.max(stem);
        if coverage <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        // Veins: midrib plus chevron laterals towards the tip.
        let midrib = 1.0 - smoothstep(0.012, 0.03, t.abs() / (1.2 - s).max(0.2));
        let lateral = ((s - t.abs() * 0.8) * 4.5 + hash01(self.seed, 7, 81)).fract();
        let lateral = (1.0 - smoothstep(0.0, 0.06, lateral.min(1.0 - lateral))) * smoothstep(0.0, 0.25, w - t.abs());
        let vein = midrib.max(lateral * 0.7) * blade;
        // Gently curled: higher along the midrib, veins slightly raised.
        let curl = if w > 0.0 { 1.0 - (t / w).powi(2).min(1.0) } else { 0.0 };
        let height = self.half_length * (0.08 * curl + 0.02 * vein) + 0.002 * stem;
        (coverage, vein, height)
    }
}

/// Several leaves scattered over the decal (oranges, browns, yellows and a green one), each
/// with a stem, midrib and lateral veins, dry darker edges and spots; the normal map shows the
/// curl and the veins. 256² texels.
pub fn leaves() -> DecalTextureSet {
    const SIZE: u32 = 256;
    const PALETTE: [Vec3; 6] = [
        Vec3::new(0.62, 0.2, 0.025),  // orange
        Vec3::new(0.2, 0.085, 0.025), // brown
        Vec3::new(0.55, 0.36, 0.03),  // yellow ochre
        Vec3::new(0.15, 0.24, 0.035), // green
        Vec3::new(0.42, 0.07, 0.02),  // red-brown
        Vec3::new(0.3, 0.14, 0.035),  // tan
    ];
    // Jittered 3×3 grid, one leaf per cell, so the leaves spread without piling up.
    let cells = [0u32, 4, 2, 6, 8, 1, 3, 5, 7];
    let leaves: Vec<Leaf> = cells
        .iter()
        .enumerate()
        .map(|(i, &cell)| {
            let i = i as u32;
            let half_length = 0.11 + 0.05 * hash01(i, 0, 71);
            let angle = TAU * hash01(i, 1, 71);
            let axis = Vec2::new(angle.cos(), angle.sin());
            let (gx, gy) = ((cell % 3) as f32, (cell / 3) as f32);
            let jitter = Vec2::new(hash01(i, 2, 71), hash01(i, 3, 71)) - 0.5;
            // Keep the whole leaf (1.3 half lengths with the stem) clear of the border.
            let reach = half_length * 1.3 + 0.06;
            let centre = ((Vec2::new(gx, gy) + 0.5 + jitter * 0.6) / 3.0).clamp(Vec2::splat(reach), Vec2::splat(1.0 - reach));
            Leaf {
                centre,
                axis,
                half_length,
                width: 0.38 + 0.14 * hash01(i, 4, 71),
                shape: hash(i, 5, 71) % 3,
                color: PALETTE[((i + hash(0, 6, 71)) % PALETTE.len() as u32) as usize],
                seed: i,
            }
        })
        .collect();
    render(LEAVES, SIZE, Maps { normal: true, metallic_roughness: false }, |uv| {
        let texel = 1.0 / SIZE as f32;
        let mut color = Vec3::new(0.2, 0.1, 0.035);
        let mut coverage = 0.0f32;
        let mut height = 0.0f32;
        // Later leaves lie on top of earlier ones.
        for (layer, leaf) in leaves.iter().enumerate() {
            let (c, vein, h) = leaf.sample(uv, texel);
            if c <= 0.0 {
                continue;
            }
            let blotch = fbm(uv, 8, 90 + leaf.seed);
            let spots = smoothstep(0.74, 0.8, value_noise(uv, 40, 95 + leaf.seed));
            let dry = smoothstep(0.0, 0.5, 1.0 - (leaf.centre - uv).length() / leaf.half_length);
            let mut leaf_color = leaf.color * (0.7 + 0.6 * blotch);
            leaf_color = leaf_color.lerp(leaf.color * 0.35, (1.0 - dry) * 0.6);
            leaf_color = leaf_color.lerp(Vec3::new(0.08, 0.04, 0.015), spots * 0.8);
            leaf_color = leaf_color.lerp(leaf.color * 1.5 + 0.05, vein * 0.45);
            color = color.lerp(leaf_color, c);
            coverage = coverage.max(c);
            let stacked = h + 0.004 * layer as f32;
            height = height + (stacked - height) * c;
        }
        Texel::new(color, coverage, height)
    })
}

/// Distance from `p` (relative to the centre) to the sigil's strokes, in UV units.
fn sigil_distance(p: Vec2, glyphs: &[[(Vec2, Vec2); 3]]) -> f32 {
    let r = p.length();
    let theta = p.y.atan2(p.x);
    let ring = |radius: f32| (r - radius).abs();
    let mut d = ring(0.445).min(ring(0.43)).min(ring(0.345)).min(ring(0.27)).min(ring(0.1));
    d = d.min(ring(0.035));
    // Hexagram inscribed in the r = 0.27 ring.
    let corner = |k: u32, offset: f32| {
        let a = offset + k as f32 * TAU / 3.0;
        Vec2::new(a.cos(), a.sin()) * 0.27
    };
    for offset in [PI / 2.0, -PI / 2.0] {
        for k in 0..3 {
            d = d.min(segment_distance(p, corner(k, offset), corner(k + 1, offset)));
        }
    }
    // Twelve spokes between the inner rings.
    let spoke = (theta / (TAU / 12.0)).round() * (TAU / 12.0);
    let dir = Vec2::new(spoke.cos(), spoke.sin());
    d = d.min(segment_distance(p, dir * 0.1, dir * 0.155));
    // Runes in the band between 0.345 and 0.43, separated by ticks.
    let slots = glyphs.len().max(1) as f32;
    let slot = ((theta.rem_euclid(TAU) / TAU) * slots).floor();
    let tick = (slot + 1.0) / slots * TAU;
    let tick_dir = Vec2::new(tick.cos(), tick.sin());
    d = d.min(segment_distance(p, tick_dir * 0.355, tick_dir * 0.42));
    let prev_tick = slot / slots * TAU;
    let prev_dir = Vec2::new(prev_tick.cos(), prev_tick.sin());
    d = d.min(segment_distance(p, prev_dir * 0.355, prev_dir * 0.42));
    if let Some(strokes) = glyphs.get(slot as usize) {
        let centre_angle = (slot + 0.5) / slots * TAU;
        let radial = Vec2::new(centre_angle.cos(), centre_angle.sin());
        let tangent = radial.perp();
        let local = p - radial * 0.3875;
        let q = Vec2::new(local.dot(tangent), local.dot(radial));
        for &(a, b) in strokes {
            d = d.min(segment_distance(q, a, b));
        }
    }
    d
}

/// A glowing magic circle: double outer ring, a band of runes between tick marks, an inner
/// ring with a hexagram, spokes and a centre eye, cyan cores in a violet-blue glow. Albedo
/// only. 256² texels.
pub fn sigil() -> DecalTextureSet {
    const SIZE: u32 = 256;
    const SLOTS: u32 = 14;
    // Each rune: three strokes between points of a 3×3 grid spanning ±(0.028, 0.026).
    let grid = |k: u32| Vec2::new((k % 3) as f32 - 1.0, (k / 3) as f32 - 1.0) * Vec2::new(0.028, 0.026);
    let glyphs: Vec<[(Vec2, Vec2); 3]> = (0..SLOTS)
        .map(|slot| {
            std::array::from_fn(|stroke| {
                let a = hash(slot, stroke as u32, 121) % 9;
                // A different end point, so no stroke degenerates to a dot.
                let b = (a + 1 + hash(slot, stroke as u32, 122) % 8) % 9;
                (grid(a), grid(b))
            })
        })
        .collect();
    render(SIGIL, SIZE, Maps { normal: false, metallic_roughness: false }, |uv| {
        let p = uv - 0.5;
        let d = sigil_distance(p, &glyphs);
        let texel = 1.0 / SIZE as f32;
        let half_width = 0.0035;
        let core = 1.0 - smoothstep(half_width - texel, half_width + texel, d);
        let glow = (-d / 0.012).exp();
        let haze = 0.12 * (1.0 - smoothstep(0.4, 0.46, p.length()));
        let coverage = core.max(glow * 0.75).max(haze);
        let glow_color = Vec3::new(0.18, 0.35, 1.0);
        let core_color = Vec3::new(0.75, 0.97, 1.0);
        let color = glow_color.lerp(core_color, core.max(glow * glow * 0.5));
        Texel::new(color, coverage, 0.0)
    })
}

/// The sigil's emission: its texture's colour × this, about 3× as bright as a white wall in the
/// courtyard's sun, so the rune glows and blooms.
pub const SIGIL_GLOW: f32 = 3.0;

/// All built-in sets, in the order bullet hole, footprint, puddle, leaves, sigil.
pub fn all() -> Vec<DecalTextureSet> {
    vec![bullet_hole(), footprint(), puddle(), leaves(), sigil()]
}

/// Adds the set's images to the world's `Assets<Image>` (compressed as the world's
/// [`crate::assets::ImportOptions`] say, [`crate::assets::import_generated`]) and returns a
/// material that uses them:
///
/// | set | albedo (factor) | normal | roughness | emission |
/// |---|---|---|---|---|
/// | `bullet_hole` | texture × 1 | yes | — | — |
/// | `footprint` | texture × (1, 1, 1, 0.9) | yes (scale 0.8) | — | — |
/// | `puddle` | texture × (0.6, 0.6, 0.65, 0.8) | yes | 1 × the MR map's G (0.05 in the water) | — |
/// | `leaves` | texture × 1 | yes | — | — |
/// | `sigil` | texture × 1 | — | — | the texture × [`SIGIL_GLOW`]: it glows |
///
/// Metallic is never set. A set with another name gets its albedo at factor 1 and its normal
/// and metallic-roughness maps if present (roughness 1 × G with the latter).
pub fn decal_material(set: &DecalTextureSet, world: &mut World) -> DecalMaterial {
    use engine::image::TextureRole;
    let mut add = |image: &Image, role: TextureRole| {
        let image = crate::assets::import_generated(world, image.clone(), role, set.name);
        world.get_resource_or_init::<Assets<Image>>().add(image)
    };
    let albedo = add(&set.albedo, TextureRole::Color);
    let normal = set.normal.as_ref().map(|n| add(n, TextureRole::Normal));
    let mr = set.metallic_roughness.as_ref().map(|m| add(m, TextureRole::Data));
    let (base_color, normal_scale) = match set.name {
        FOOTPRINT => (Vec4::new(1.0, 1.0, 1.0, 0.9), 0.8),
        PUDDLE => (Vec4::new(0.6, 0.6, 0.65, 0.8), 1.0),
        _ => (Vec4::ONE, 1.0),
    };
    let glows = set.name == SIGIL;
    DecalMaterial {
        emissive: glows.then_some(Vec3::splat(SIGIL_GLOW)),
        emissive_texture: glows.then_some(albedo),
        base_color_texture: Some(albedo),
        base_color: Some(base_color),
        normal_texture: normal,
        normal_scale,
        // The MR map holds the absolute roughness in G; the factor 1 passes it through.
        roughness: mr.map(|_| 1.0),
        metallic: None,
        metallic_roughness_texture: mr,
        emits_light: false,
    }
}

/// Generates every built-in set, adds its images and its material to the world's `Assets`
/// (created if missing); returns the material handles in the order of [`all`].
pub fn add_builtin_materials(world: &mut World) -> Vec<Handle<DecalMaterial>> {
    all()
        .iter()
        .map(|set| {
            let material = decal_material(set, world);
            world.get_resource_or_init::<Assets<DecalMaterial>>().add(material)
        })
        .collect()
}

/// Encodes level 0 of `image` as an RGBA8 PNG (best compression).
pub fn encode_png(image: &Image) -> Result<Vec<u8>> {
    use ::image::ImageEncoder;
    use ::image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let level0 = image.mips.first().context("image has no mip levels")?;
    let mut png = Vec::new();
    PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
        .write_image(level0, image.width, image.height, ::image::ExtendedColorType::Rgba8)
        .context("encoding PNG")?;
    Ok(png)
}

/// The PNG files of `set`: `(file name, image)` for `<name>_albedo.png`, `<name>_normal.png`
/// and `<name>_mr.png` (the latter two when present).
pub fn png_files(set: &DecalTextureSet) -> Vec<(String, &Image)> {
    let mut files = vec![(format!("{}_albedo.png", set.name), &set.albedo)];
    if let Some(normal) = &set.normal {
        files.push((format!("{}_normal.png", set.name), normal));
    }
    if let Some(mr) = &set.metallic_roughness {
        files.push((format!("{}_mr.png", set.name), mr));
    }
    files
}

/// Writes level 0 of every built-in image into `dir` (created if missing) as
/// `<name>_albedo.png`, `<name>_normal.png` and `<name>_mr.png`; returns the paths written.
pub fn write_pngs(dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    for set in all() {
        for (file, image) in png_files(&set) {
            let path = dir.join(file);
            let png = encode_png(image)?;
            std::fs::write(&path, png).with_context(|| format!("writing {}", path.display()))?;
            written.push(path);
        }
    }
    Ok(written)
}

/// Where the committed copies of the PNGs live: `assets/decals/` of the workspace.
pub fn assets_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("assets").join("decals")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_normal(texel: &[u8]) -> Vec3 {
        Vec3::new(texel[0] as f32, texel[1] as f32, texel[2] as f32) / 127.5 - 1.0
    }

    #[test]
    fn sets_have_the_promised_maps_and_formats() {
        let sets = all();
        let names: Vec<_> = sets.iter().map(|s| s.name).collect();
        assert_eq!(names, [BULLET_HOLE, FOOTPRINT, PUDDLE, LEAVES, SIGIL]);
        for set in &sets {
            assert_eq!(set.albedo.color_space, ColorSpace::Srgb, "{}", set.name);
            assert!(matches!(set.albedo.width, 128 | 256));
            assert_eq!(set.albedo.width, set.albedo.height);
            assert_eq!(set.albedo.mip_count(), 32 - set.albedo.width.leading_zeros());
            for extra in set.normal.iter().chain(&set.metallic_roughness) {
                assert_eq!(extra.color_space, ColorSpace::Linear, "{}", set.name);
                assert_eq!((extra.width, extra.height), (set.albedo.width, set.albedo.height));
                assert_eq!(extra.mip_count(), set.albedo.mip_count());
            }
            assert_eq!(set.normal.is_some(), set.name != SIGIL);
            assert_eq!(set.metallic_roughness.is_some(), set.name == PUDDLE);
        }
        assert_eq!(bullet_hole().albedo.width, 128);
    }

    #[test]
    fn generation_is_deterministic() {
        assert_eq!(all(), all());
    }

    #[test]
    fn coverage_vanishes_at_the_borders_and_exists_inside() {
        for set in all() {
            let (w, h) = (set.albedo.width as usize, set.albedo.height as usize);
            let alpha = |x: usize, y: usize| set.albedo.mips[0][(y * w + x) * 4 + 3];
            for i in 0..w {
                for (x, y) in [(i, 0), (i, h - 1), (0, i), (w - 1, i)] {
                    assert_eq!(alpha(x, y), 0, "{} border texel ({x}, {y})", set.name);
                }
            }
            let covered = (0..w * h).filter(|&i| alpha(i % w, i / w) > 128).count();
            assert!(covered * 20 > w * h, "{}: only {covered} texels covered", set.name);
            assert!(covered * 10 < w * h * 9, "{}: almost a full box", set.name);
            // The normal map carries the same coverage.
            if let Some(normal) = &set.normal {
                let same = normal.mips[0].chunks_exact(4).zip(set.albedo.mips[0].chunks_exact(4)).all(|(n, a)| n[3] == a[3]);
                assert!(same, "{}: normal alpha differs from albedo alpha", set.name);
            }
        }
    }

    #[test]
    fn normal_maps_are_unit_and_not_flat() {
        for set in all() {
            let Some(normal) = &set.normal else { continue };
            let mut tilted = 0;
            for texel in normal.mips[0].chunks_exact(4) {
                let n = decode_normal(texel);
                assert!((n.length() - 1.0).abs() < 0.02, "{}: |{n}| not unit", set.name);
                assert!(n.z > 0.0, "{}: normal {n} faces away", set.name);
                if texel[3] == 0 {
                    assert_eq!(&texel[..3], &[128, 128, 255], "{}: uncovered texel not flat", set.name);
                }
                tilted += (n.z < 0.995) as usize;
            }
            assert!(tilted > 200, "{}: only {tilted} tilted normals", set.name);
        }
    }

    #[test]
    fn bullet_hole_normals_point_into_the_crater_in_gltf_convention() {
        // The crater's walls face its centre: right of the centre the normal leans towards −X
        // (image-left), below it (larger V) towards +Y (image-up, decreasing V).
        let set = bullet_hole();
        let normal = set.normal.unwrap();
        let w = normal.width as usize;
        let at = |x: usize, y: usize| decode_normal(&normal.mips[0][(y * w + x) * 4..][..4]);
        let (c, off) = (w / 2, w / 8);
        assert!(at(c + off, c).x < -0.1, "{}", at(c + off, c));
        assert!(at(c - off, c).x > 0.1, "{}", at(c - off, c));
        assert!(at(c, c + off).y > 0.1, "{}", at(c, c + off));
        assert!(at(c, c - off).y < -0.1, "{}", at(c, c - off));
        // And the centre is dark.
        let albedo = &set.albedo.mips[0][(c * w + c) * 4..][..4];
        assert!(albedo[0] < 40 && albedo[3] == 255, "{albedo:?}");
    }

    #[test]
    fn puddle_is_smooth_in_the_middle_and_rougher_at_the_rim() {
        let set = puddle();
        let mr = set.metallic_roughness.as_ref().unwrap();
        let w = mr.width as usize;
        let texel = |x: usize, y: usize| &mr.mips[0][(y * w + x) * 4..][..4];
        let centre = texel(w / 2, w / 2);
        assert!((centre[1] as f32 / 255.0) < 0.1, "centre roughness {}", centre[1]);
        assert_eq!((centre[0], centre[2]), (0, 0), "metallic (B) is zero");
        assert!(mr.mips[0].chunks_exact(4).all(|t| t[2] == 0));
        let corner = texel(2, 2);
        assert!(corner[1] as f32 / 255.0 > 0.5, "rim roughness {}", corner[1]);
        let material = decal_material(&set, &mut rgba8_world());
        let effective = material.roughness.unwrap() * centre[1] as f32 / 255.0;
        assert!(effective < 0.1 && effective > 0.0);
    }

    /// A world whose generated textures stay RGBA8.
    fn rgba8_world() -> World {
        let mut world = World::new();
        let options = engine::gltf::LoadOptions { textures: engine::gltf::TextureImport::Rgba8, ..Default::default() };
        world.insert_resource(crate::assets::ImportOptions(options));
        world
    }

    #[test]
    fn materials_reference_the_added_images() {
        let mut world = rgba8_world();
        for set in all() {
            let before = world.get_resource_or_init::<Assets<Image>>().len();
            let m = decal_material(&set, &mut world);
            let images = world.resource::<Assets<Image>>();
            let added = 1 + set.normal.is_some() as usize + set.metallic_roughness.is_some() as usize;
            assert_eq!(images.len(), before + added, "{}", set.name);
            assert_eq!(images.get(m.base_color_texture.unwrap()), Some(&set.albedo));
            assert_eq!(m.normal_texture.and_then(|h| images.get(h)), set.normal.as_ref());
            assert_eq!(m.metallic_roughness_texture.and_then(|h| images.get(h)), set.metallic_roughness.as_ref());
            assert!(m.base_color.is_some() && m.metallic.is_none());
            assert_eq!(m.roughness.is_some(), set.name == PUDDLE);
            assert_eq!(m.emissive.is_some(), set.name == SIGIL);
            assert_eq!(m.emissive_texture, m.emissive.and(m.base_color_texture));
        }
        let puddle = decal_material(&puddle(), &mut world);
        assert_eq!(puddle.base_color, Some(Vec4::new(0.6, 0.6, 0.65, 0.8)));
        let handles = add_builtin_materials(&mut world);
        assert_eq!(handles.len(), 5);
        let materials = world.resource::<Assets<DecalMaterial>>();
        assert!(handles.iter().all(|&h| materials.contains(h)));
    }

    #[test]
    fn generated_textures_are_compressed_when_imports_are() {
        let mut world = World::new();
        let options = engine::gltf::LoadOptions {
            textures: engine::gltf::TextureImport::Compressed(engine::gltf::CacheLocation::Off),
            ..Default::default()
        };
        world.insert_resource(crate::assets::ImportOptions(options));
        let m = decal_material(&bullet_hole(), &mut world);
        let images = world.resource::<Assets<Image>>();
        let format = |h: Option<Handle<Image>>| h.and_then(|h| images.get(h)).map(|i| i.format);
        assert_eq!(format(m.base_color_texture), Some(engine::image::TexelFormat::Bc7));
        assert_eq!(format(m.normal_texture), Some(engine::image::TexelFormat::Bc5));
        let totals = world.resource::<crate::assets::ImportTotals>().0;
        assert_eq!(totals.compressed, 2, "{totals:?}");
    }

    #[test]
    fn pngs_in_assets_match_the_generator() {
        let dir = assets_dir();
        let mut total = 0u64;
        let mut count = 0;
        for set in all() {
            for (file, image) in png_files(&set) {
                let path = dir.join(&file);
                let bytes = std::fs::read(&path)
                    .unwrap_or_else(|e| panic!("{}: {e}; regenerate with `cargo run -p sandbox --bin gen_decal_textures`", path.display()));
                total += bytes.len() as u64;
                count += 1;
                let decoded = ::image::load_from_memory(&bytes).unwrap().into_rgba8();
                assert_eq!(decoded.dimensions(), (image.width, image.height), "{file}");
                assert!(decoded.as_raw() == &image.mips[0], "{file} differs from the generator");
            }
        }
        assert_eq!(count, 10);
        assert!(total < 600 * 1024, "decal PNGs take {total} bytes");
    }

    #[test]
    fn write_pngs_writes_every_file_as_the_generator_makes_it() {
        // What the `gen_decal_textures` tool does, into a scratch directory.
        let dir = std::env::temp_dir().join(format!("decal-pngs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let written = write_pngs(&dir).unwrap();
        let sets = all();
        let expected: Vec<_> = sets.iter().flat_map(png_files).collect();
        assert_eq!(written.len(), expected.len());
        for (path, (file, image)) in written.iter().zip(&expected) {
            assert_eq!(path, &dir.join(file));
            let decoded = ::image::open(path).unwrap().into_rgba8();
            assert!(decoded.as_raw() == &image.mips[0], "{file} differs from the generator");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn write_pngs_reports_an_unwritable_directory() {
        let file = std::env::temp_dir().join(format!("decal-pngs-not-a-dir-{}", std::process::id()));
        std::fs::write(&file, b"x").unwrap();
        assert!(write_pngs(&file.join("sub")).is_err());
        let _ = std::fs::remove_file(&file);
    }
}
