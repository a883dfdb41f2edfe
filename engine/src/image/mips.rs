//! Mip chains: each level an area-weighted box filter of the one above, colour filtered in
//! linear space.
//!
//! Mip sizes follow Vulkan's rule, level `l` is `max(1, size >> l)` (so 5×3 → 2×1 → 1×1), which
//! lets the renderer copy each level into a `VkImage` of the level-0 extent directly. Each level
//! is an area-weighted box filter of the one above: a plain 2×2 average for even sizes; for an
//! odd size `2d + 1` each destination texel covers `2 + 1/d` source texels (up to three taps with
//! fractional edge weights), so no source texel is dropped or over-weighted. For sRGB images the colour channels are filtered in linear space (decoded through a
//! 256-entry table, re-encoded by a binary search over the 255 code midpoints, i.e. exact
//! round-to-nearest in sRGB); alpha is always linear. Levels are filtered from the previous
//! level's unquantised floats, so rounding does not accumulate down the chain.

use super::*;
use std::sync::OnceLock;

/// sRGB code → linear value, and the linear values halfway between consecutive codes.
pub(super) struct SrgbTables {
    pub(super) decode: [f32; 256],
    pub(super) midpoints: [f32; 255],
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

pub(super) fn srgb_tables() -> &'static SrgbTables {
    static TABLES: OnceLock<SrgbTables> = OnceLock::new();
    TABLES.get_or_init(|| SrgbTables {
        decode: std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0) as f32),
        midpoints: std::array::from_fn(|i| srgb_to_linear((i as f64 + 0.5) / 255.0) as f32),
    })
}

fn encode_linear(v: f32) -> u8 {
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// One destination texel's source coverage along an axis: up to three weighted source texels.
#[derive(Clone, Copy)]
struct Taps {
    first: usize,
    count: usize,
    weights: [f32; 3],
}

/// Area-weighted box-filter taps from `src` texels down to `dst` texels.
fn axis_taps(src: u32, dst: u32) -> Vec<Taps> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|x| {
            let (start, end) = (x as f64 * scale, (x + 1) as f64 * scale);
            let first = start.floor() as usize;
            let last = (end.ceil() as usize).min(src as usize);
            let mut taps = Taps { first, count: 0, weights: [0.0; 3] };
            for i in first..last {
                let overlap = (end.min(i as f64 + 1.0) - start.max(i as f64)).max(0.0);
                if taps.count < 3 {
                    taps.weights[taps.count] = (overlap / scale) as f32;
                    taps.count += 1;
                }
            }
            taps
        })
        .collect()
}

/// Downsamples a `w`×`h` RGBA float image (read through `fetch(index)`) to `nw`×`nh`.
fn downsample(w: u32, h: u32, nw: u32, nh: u32, fetch: impl Fn(usize) -> f32) -> Vec<f32> {
    let (w, h, nw, nh) = (w as usize, h as usize, nw as usize, nh as usize);
    let tx = axis_taps(w as u32, nw as u32);
    let ty = axis_taps(h as u32, nh as u32);
    let mut rows = vec![0.0f32; nw * h * 4];
    for y in 0..h {
        for (x, taps) in tx.iter().enumerate() {
            let out = &mut rows[(y * nw + x) * 4..][..4];
            for k in 0..taps.count {
                let base = (y * w + taps.first + k) * 4;
                for (c, o) in out.iter_mut().enumerate() {
                    *o += taps.weights[k] * fetch(base + c);
                }
            }
        }
    }
    let mut out = vec![0.0f32; nw * nh * 4];
    for (y, taps) in ty.iter().enumerate() {
        let dst = &mut out[y * nw * 4..][..nw * 4];
        for k in 0..taps.count {
            let src = &rows[(taps.first + k) * nw * 4..][..nw * 4];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += taps.weights[k] * s;
            }
        }
    }
    out
}

/// What a mip chain filters: colours (or other data) as they are, or unit vectors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum MipFilter {
    /// Each channel filtered on its own.
    Plain,
    /// A tangent-space normal map (`xyz = 2·rgb − 1`, linear): after filtering, each texel's
    /// vector is renormalised, so that a minified normal stays unit length (a box filter alone
    /// shortens them wherever the surface is bumpy, which darkens and flattens distant shading).
    Normals,
}

/// Renormalises the RGB of each RGBA float texel as a `2·rgb − 1` vector (a zero vector
/// becomes straight up, `(0.5, 0.5, 1)`).
fn renormalise(texels: &mut [f32]) {
    for texel in texels.chunks_exact_mut(4) {
        let v = [texel[0] * 2.0 - 1.0, texel[1] * 2.0 - 1.0, texel[2] * 2.0 - 1.0];
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let unit = if length > 1e-6 { v.map(|c| c / length) } else { [0.0, 0.0, 1.0] };
        for (out, c) in texel.iter_mut().zip(unit) {
            *out = c * 0.5 + 0.5;
        }
    }
}

pub(super) fn build_mips(width: u32, height: u32, level0: Vec<u8>, color_space: ColorSpace, filter: MipFilter) -> Vec<Vec<u8>> {
    let tables = srgb_tables();
    let levels = 32 - width.max(height).leading_zeros();
    let mut mips = Vec::with_capacity(levels as usize);
    let mut previous: Vec<f32> = Vec::new();
    let (mut w, mut h) = (width, height);
    mips.push(level0);
    for level in 1..levels {
        let (nw, nh) = mip_size(width, height, level);
        let next = if level == 1 {
            let src = &mips[0];
            match color_space {
                ColorSpace::Srgb => {
                    downsample(w, h, nw, nh, |i| if i % 4 == 3 { src[i] as f32 / 255.0 } else { tables.decode[src[i] as usize] })
                }
                ColorSpace::Linear => downsample(w, h, nw, nh, |i| src[i] as f32 / 255.0),
            }
        } else {
            downsample(w, h, nw, nh, |i| previous[i])
        };
        let mut next = next;
        if filter == MipFilter::Normals {
            renormalise(&mut next);
        }
        let bytes = next
            .iter()
            .enumerate()
            .map(|(i, &v)| match color_space {
                ColorSpace::Srgb if i % 4 != 3 => tables.midpoints.partition_point(|&m| m <= v) as u8,
                _ => encode_linear(v),
            })
            .collect();
        mips.push(bytes);
        previous = next;
        (w, h) = (nw, nh);
    }
    mips
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_sizes_follow_vulkan_mip_rule() {
        let image = Image::from_rgba8(5, 3, vec![200; 5 * 3 * 4], ColorSpace::Linear).unwrap();
        let sizes: Vec<_> = (0..image.mip_count()).map(|l| image.mip_size(l)).collect();
        assert_eq!(sizes, vec![(5, 3), (2, 1), (1, 1)]);
        for (level, data) in image.mips.iter().enumerate() {
            let (w, h) = sizes[level];
            assert_eq!(data.len(), (w * h * 4) as usize);
            assert!(data.iter().all(|&v| v == 200), "constant image stays constant");
        }
        let tall = Image::from_rgba8(1, 6, vec![0; 24], ColorSpace::Srgb).unwrap();
        assert_eq!(tall.mip_count(), 3);
        assert_eq!(tall.mips[2].len(), 4);
    }

    #[test]
    fn odd_filter_keeps_every_texel() {
        // A 3x1 row 0, 255, 0 (linear): the 1x1 mip is the area average 85, not 0 or 127.
        let data = [0u8, 255, 0].iter().flat_map(|&v| [v, v, v, 255]).collect();
        let image = Image::from_rgba8(3, 1, data, ColorSpace::Linear).unwrap();
        assert_eq!(image.mips[1], vec![85, 85, 85, 255]);
    }

    #[test]
    fn srgb_average_is_done_in_linear_space() {
        let (b, w) = ([0u8, 0, 0, 255], [255u8, 255, 255, 255]);
        let checker: Vec<u8> = [b, w, w, b].concat();
        let srgb = Image::from_rgba8(2, 2, checker.clone(), ColorSpace::Srgb).unwrap();
        assert_eq!(srgb.mip_count(), 2);
        assert_eq!(&srgb.mips[1][..3], &[188, 188, 188]);
        assert_eq!(srgb.mips[1][3], 255);
        let linear = Image::from_rgba8(2, 2, checker, ColorSpace::Linear).unwrap();
        assert_eq!(&linear.mips[1][..3], &[128, 128, 128]);
    }

    #[test]
    fn srgb_round_trip_is_exact() {
        let tables = srgb_tables();
        for code in 0..=255u8 {
            let v = tables.decode[code as usize];
            assert_eq!(tables.midpoints.partition_point(|&m| m <= v), code as usize);
        }
    }
}
