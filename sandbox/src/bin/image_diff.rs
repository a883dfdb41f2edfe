//! Puts two screenshots of the same size side by side with their difference, for pictures of
//! what a change does to an image (`docs/content_textures.png`), and prints the error:
//!
//! ```sh
//! cargo run -p sandbox --bin image_diff -- BEFORE.png AFTER.png OUT.png [AMPLIFY]
//! ```
//!
//! The third panel is the absolute difference of each channel times AMPLIFY (default 8); the
//! printed figures are the mean, 99th percentile and largest difference over every colour
//! channel, in 8-bit values.

#![forbid(unsafe_code)]

use anyhow::{Context, Result, ensure};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    ensure!(args.len() >= 3, "usage: image_diff BEFORE.png AFTER.png OUT.png [AMPLIFY]");
    let open = |path: &str| image::open(path).with_context(|| format!("reading {path}")).map(|i| i.into_rgba8());
    let (a, b) = (open(&args[0])?, open(&args[1])?);
    ensure!(a.dimensions() == b.dimensions(), "the images differ in size: {:?} and {:?}", a.dimensions(), b.dimensions());
    let amplify: f32 = args.get(3).map(|s| s.parse()).transpose().context("AMPLIFY is a number")?.unwrap_or(8.0);
    let (w, h) = a.dimensions();
    let mut out = image::RgbaImage::new(w * 3, h);
    let mut errors = Vec::with_capacity((w * h * 3) as usize);
    for (x, y, pa) in a.enumerate_pixels() {
        let pb = b.get_pixel(x, y);
        let mut diff = [0u8, 0, 0, 255];
        for c in 0..3 {
            let d = pa[c].abs_diff(pb[c]);
            errors.push(d);
            diff[c] = (d as f32 * amplify).min(255.0) as u8;
        }
        out.put_pixel(x, y, *pa);
        out.put_pixel(x + w, y, *pb);
        out.put_pixel(x + 2 * w, y, image::Rgba(diff));
    }
    errors.sort_unstable();
    let mean = errors.iter().map(|&e| e as f64).sum::<f64>() / errors.len() as f64;
    println!(
        "mean {mean:.3}, 99th percentile {}, largest {} (8-bit values; difference panel ×{amplify})",
        errors[errors.len() * 99 / 100],
        errors[errors.len() - 1]
    );
    out.save(&args[2]).with_context(|| format!("writing {}", args[2]))
}
