//! Loading glTF files the way the sandbox was told to import textures (`--textures`,
//! `--asset-cache`), the same for the textures the sandbox generates (the courtyard's and the
//! built-in decals', [`import_generated`]), the running count of what the imports did (for
//! `--stats`), and the `bake` command: compress a model's textures into the cache ahead of time,
//! or measure what importing costs (`bake --measure`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use bevy_ecs::prelude::{Resource, World};
use engine::gltf::{CacheLocation, GltfScene, LoadOptions, TextureImport, TextureImportStats};

/// How the sandbox loads glTF files (a resource; the default when absent).
#[derive(Resource, Clone, Debug, Default)]
pub struct ImportOptions(pub LoadOptions);

/// What every glTF import of this run did to its textures, summed (a resource).
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct ImportTotals(pub TextureImportStats);

impl ImportTotals {
    fn count(&mut self, source: engine::gltf::TextureSource) {
        self.0.count(source);
    }

    fn add(&mut self, stats: &TextureImportStats) {
        self.0 += stats;
    }
}

/// Loads a glTF file with the world's [`ImportOptions`], adding what its texture import did to
/// [`ImportTotals`].
pub fn load_gltf(world: &mut World, path: &Path) -> Result<GltfScene, engine::gltf::GltfError> {
    let options = world.get_resource::<ImportOptions>().cloned().unwrap_or_default();
    let scene = engine::gltf::load_with(path, &options.0)?;
    world.get_resource_or_insert_with(ImportTotals::default).add(&scene.texture_import);
    Ok(scene)
}

/// A texture the sandbox generated (RGBA8 with mips), imported as the world's [`ImportOptions`]
/// import glTF textures: compressed for `role` through the cache (keyed by its texels, so a
/// generator that changes misses), or kept as it is. Counted in [`ImportTotals`].
pub fn import_generated(
    world: &mut World,
    image: engine::image::Image,
    role: engine::image::TextureRole,
    name: &str,
) -> engine::image::Image {
    use engine::gltf::TextureSource;
    use engine::image::Image;
    let options = world.get_resource::<ImportOptions>().cloned().unwrap_or_default();
    let TextureImport::Compressed(location) = &options.0.textures else {
        return image;
    };
    let (width, height) = (image.width, image.height);
    let Some(level0) = image.mips.first().filter(|_| image.format == engine::image::TexelFormat::Rgba8).cloned() else {
        return image;
    };
    let compressed = match location.cache() {
        Some(cache) => {
            let mut source = format!("generated {width}x{height} rgba8:").into_bytes();
            source.extend_from_slice(&level0);
            cache
                .load_or_compress(&source, role, name, || Ok((width, height, level0.clone())))
                .map(|(image, outcome)| (image, TextureSource::from(&outcome)))
        }
        None => Image::compress(width, height, level0.clone(), role).map(|image| (image, TextureSource::Compressed)),
    };
    match compressed {
        Ok((compressed, how)) => {
            world.get_resource_or_insert_with(ImportTotals::default).count(how);
            compressed
        }
        Err(error) => {
            tracing::warn!(texture = name, %error, "a generated texture could not be compressed; it stays RGBA8");
            image
        }
    }
}

/// The import options the command line asks for: `rgba8` or compressed textures (`bc`), cached
/// in `cache` (the user's cache folder when `None`; `off`: no cache), and a progress bar on the
/// terminal while textures are compressed.
pub fn import_options(textures: &str, cache: Option<&Path>, progress: bool) -> Result<LoadOptions> {
    let location = match cache {
        Some(dir) if dir == Path::new("off") => CacheLocation::Off,
        Some(dir) => CacheLocation::At(dir.to_owned()),
        None => CacheLocation::User,
    };
    let textures = match textures {
        "bc" => TextureImport::Compressed(location),
        "rgba8" => TextureImport::Rgba8,
        other => anyhow::bail!("unknown texture import {other:?} (bc, rgba8)"),
    };
    Ok(LoadOptions { textures, progress: progress.then(progress_bar), ..Default::default() })
}

/// A progress line on standard error while a model's textures are compressed (shown only when
/// one needs compressing: a cached load stays silent).
fn progress_bar() -> engine::gltf::TextureProgress {
    use std::io::{IsTerminal, Write};
    use std::sync::atomic::{AtomicBool, Ordering};
    let started = Instant::now();
    let shown = AtomicBool::new(false);
    std::sync::Arc::new(move |event: &engine::gltf::TextureEvent<'_>| {
        if !std::io::stderr().is_terminal() {
            return;
        }
        let compressing = matches!(event.import, engine::gltf::TextureSource::Compressed | engine::gltf::TextureSource::Rebuilt);
        let mut err = std::io::stderr().lock();
        if compressing {
            shown.store(true, Ordering::Relaxed);
            let width = 30;
            let filled = event.done * width / event.total.max(1);
            let _ = write!(
                err,
                "\rcompressing textures [{}{}] {}/{} {:.1} s {}\x1b[K",
                "#".repeat(filled),
                " ".repeat(width - filled),
                event.done,
                event.total,
                started.elapsed().as_secs_f32(),
                event.image
            );
        }
        // The line ends with the model's last image, whatever it was.
        if event.done == event.total && shown.swap(false, Ordering::Relaxed) {
            let _ = writeln!(err);
        }
    })
}

/// What importing one file cost (`bake --measure`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ImportMeasure {
    /// The file.
    pub file: PathBuf,
    /// Texture images the file's materials use (image, role pairs).
    pub images: usize,
    /// Load time with RGBA8 textures (PNG/JPEG decoded, mips filtered), seconds.
    pub rgba8_seconds: f64,
    /// Load time with an empty cache (decoded, filtered, compressed, written), seconds.
    pub first_seconds: f64,
    /// Load time from the cache, seconds.
    pub cached_seconds: f64,
    /// Bytes of every texture level as RGBA8.
    pub rgba8_bytes: u64,
    /// Bytes of every texture level compressed.
    pub compressed_bytes: u64,
    /// Texture bytes by format, compressed.
    pub compressed_by_format: std::collections::BTreeMap<String, u64>,
}

fn texture_bytes(scene: &GltfScene) -> u64 {
    scene.images.iter().flat_map(|image| &image.mips).map(|level| level.len() as u64).sum()
}

/// Loads `file` three ways (RGBA8; compressed into an empty cache under `scratch`; compressed
/// from that cache) and reports the times and texture bytes of each.
pub fn measure_import(file: &Path, scratch: &Path) -> Result<ImportMeasure> {
    let load = |options: &LoadOptions| -> Result<(GltfScene, f64)> {
        let started = Instant::now();
        let scene = engine::gltf::load_with(file, options).with_context(|| format!("loading {}", file.display()))?;
        Ok((scene, started.elapsed().as_secs_f64()))
    };
    let cache = scratch.join(format!("bake-measure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let compressed = LoadOptions { textures: TextureImport::Compressed(CacheLocation::At(cache.clone())), ..Default::default() };
    let (rgba8, rgba8_seconds) = load(&LoadOptions { textures: TextureImport::Rgba8, ..Default::default() })?;
    let (first, first_seconds) = load(&compressed)?;
    let (cached, cached_seconds) = load(&compressed)?;
    let _ = std::fs::remove_dir_all(&cache);
    anyhow::ensure!(
        cached.texture_import.compressed + cached.texture_import.rebuilt == 0,
        "the second load did not read every texture from the cache: {:?}",
        cached.texture_import
    );
    let mut by_format = std::collections::BTreeMap::new();
    for image in &first.images {
        *by_format.entry(format!("{:?}", image.format)).or_default() += image.mips.iter().map(|l| l.len() as u64).sum::<u64>();
    }
    Ok(ImportMeasure {
        file: file.to_owned(),
        images: first.images.len(),
        rgba8_seconds,
        first_seconds,
        cached_seconds,
        rgba8_bytes: texture_bytes(&rgba8),
        compressed_bytes: texture_bytes(&first),
        compressed_by_format: by_format,
    })
}

/// Compresses the textures of `file` into the cache `options` name (what its first load would
/// do) and says what it did.
pub fn bake(file: &Path, options: &LoadOptions) -> Result<String> {
    let started = Instant::now();
    let scene = engine::gltf::load_with(file, options).with_context(|| format!("loading {}", file.display()))?;
    let s = scene.texture_import;
    Ok(format!(
        "{}: {} texture images in {:.2} s: {} compressed, {} already cached, {} rebuilt, {} KTX2 used as they are, {} MiB of textures",
        file.display(),
        scene.images.len(),
        started.elapsed().as_secs_f64(),
        s.compressed,
        s.cache_hits,
        s.rebuilt,
        s.ktx2,
        texture_bytes(&scene) as f64 / (1024.0 * 1024.0)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared Fox (one 1024² PNG base colour); a missing file fails the test.
    fn fox() -> PathBuf {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/assets/gltf/Fox/Fox.glb");
        assert!(path.exists(), "{} is missing (the shared models live beside the project)", path.display());
        path
    }

    #[test]
    fn measuring_an_import_loads_three_ways_and_counts_a_quarter_of_the_bytes() {
        let scratch = std::env::temp_dir().join(format!("ecs-decals-measure-{}", std::process::id()));
        let m = measure_import(&fox(), &scratch).expect("the Fox imports");
        assert_eq!(m.images, 1);
        // BC7: a byte a texel where RGBA8 takes four, but for the levels smaller than a block.
        assert_eq!(m.rgba8_bytes, 5_592_404);
        assert_eq!(m.compressed_bytes, 1_398_128);
        assert_eq!(m.compressed_by_format.get("Bc7"), Some(&1_398_128));
        let _ = std::fs::remove_dir_all(&scratch);
    }

    #[test]
    fn baking_fills_the_cache_the_next_load_reads() {
        let dir = std::env::temp_dir().join(format!("ecs-decals-bake-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let options = import_options("bc", Some(&dir), false).expect("valid options");
        let first = bake(&fox(), &options).expect("the Fox bakes");
        assert!(first.contains("1 compressed, 0 already cached"), "{first}");
        let second = bake(&fox(), &options).expect("the Fox bakes again");
        assert!(second.contains("0 compressed, 1 already cached"), "{second}");
        assert!(import_options("astc", None, false).is_err(), "an unknown import is refused");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
