//! The texture import cache: a texture compressed once ([`super::compress`]) is written as a KTX2
//! file that later loads read directly, with no PNG/JPEG decoding, mip filtering or compression.
//!
//! **Keys.** A file is named by the BLAKE3 hash of the source image's encoded bytes (the PNG or
//! JPEG as the glTF holds it, so a renamed or moved file still hits and an edited one misses)
//! and the settings that shaped it: the [`TextureRole`] and [`CACHE_VERSION`] (bumped whenever the
//! encoder, its profile or the mip filter change). The whole key is also written into the
//! file's metadata (`ecs-decals.key`) with the BLAKE3 hash of its levels (`ecs-decals.blocks`),
//! and a read checks both, the format the role asks for and a full mip chain: a truncated,
//! corrupt or mismatched file is never used; it is rebuilt with a warning and overwritten.
//!
//! **Where.** [`TextureCache::user`] is `$XDG_CACHE_HOME/ecs-decals/textures`, else
//! `~/.cache/ecs-decals/textures`; any folder can be given instead ([`TextureCache::new`]; the
//! sandbox's `--asset-cache DIR`). Files are written to a temporary name and renamed into
//! place, so processes loading the same model at once never read a half-written file. A cache
//! that cannot be written costs a warning, not the load. Nothing is ever deleted: an edited
//! texture leaves its old file behind, which deleting the folder clears.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::*;

/// Bumped whenever what a cached file holds for the same key would change: the encoder or its
/// settings, the mip filter, the role-to-format table.
pub const CACHE_VERSION: u32 = 1;

/// The metadata key holding a cached file's full cache key.
const KEY_METADATA: &str = "ecs-decals.key";

/// The metadata key holding the BLAKE3 hash of a cached file's levels (level 0 first).
const BLOCKS_METADATA: &str = "ecs-decals.blocks";

/// The hash of an image's levels, level 0 first.
fn blocks_hash(image: &Image) -> String {
    let mut hasher = blake3::Hasher::new();
    for level in &image.mips {
        hasher.update(level);
    }
    hasher.finalize().to_hex().to_string()
}

/// A folder of compressed textures, keyed by source content and settings (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TextureCache {
    dir: PathBuf,
}

/// What [`TextureCache::load_or_compress`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheOutcome {
    /// The compressed texture was read from the cache.
    Hit,
    /// Nothing was cached for the key: the texture was compressed (and written, unless the
    /// folder could not be written, which was warned about).
    Compressed,
    /// A cached file existed but could not be used (truncated, corrupt, or made for another
    /// key): the texture was compressed again and the file overwritten. Holds why.
    Rebuilt(String),
}

impl TextureCache {
    /// A cache in `dir` (created when the first texture is written).
    pub fn new(dir: impl Into<PathBuf>) -> TextureCache {
        TextureCache { dir: dir.into() }
    }

    /// The user's cache: `$XDG_CACHE_HOME/ecs-decals/textures`, else
    /// `$HOME/.cache/ecs-decals/textures` (`None` when neither variable is set).
    pub fn user() -> Option<TextureCache> {
        let base = std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").filter(|v| !v.is_empty()).map(|home| PathBuf::from(home).join(".cache")))?;
        Some(TextureCache::new(base.join("ecs-decals").join("textures")))
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The cache key of `source` (encoded image bytes) compressed for `role`.
    pub fn key(source: &[u8], role: TextureRole) -> String {
        let hash = blake3::hash(source);
        format!("{}-{}-v{CACHE_VERSION}", hash.to_hex(), role.name())
    }

    /// The file a key is stored in.
    pub fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.ktx2"))
    }

    /// The texture `source` compressed for `role`: read from the cache when a valid file holds
    /// it, else made by decoding with `decode` (to RGBA8 level 0: width, height, texels) and
    /// compressing, then written to the cache. `what` names the image in warnings.
    pub fn load_or_compress(
        &self,
        source: &[u8],
        role: TextureRole,
        what: &str,
        decode: impl FnOnce() -> Result<(u32, u32, Vec<u8>), ImageError>,
    ) -> Result<(Image, CacheOutcome), ImageError> {
        let key = TextureCache::key(source, role);
        let path = self.path(&key);
        let outcome = match std::fs::read(&path) {
            Ok(bytes) => match read_cached(&bytes, &key, role, what) {
                Ok(image) => return Ok((image, CacheOutcome::Hit)),
                Err(reason) => {
                    tracing::warn!(file = %path.display(), image = what, %reason, "the cached texture cannot be used; compressing it again");
                    CacheOutcome::Rebuilt(reason)
                }
            },
            Err(_) => CacheOutcome::Compressed,
        };
        let (width, height, rgba) = decode()?;
        let image = Image::compress(width, height, rgba, role)?;
        let blocks = blocks_hash(&image);
        if let Err(error) = self.write(&path, &image.to_ktx2(&[(KEY_METADATA, &key), (BLOCKS_METADATA, &blocks)])) {
            tracing::warn!(folder = %self.dir.display(), %error, "the texture cache cannot be written; the texture will be compressed again next time");
        }
        Ok((image, outcome))
    }

    /// Writes `bytes` to `path` through a temporary file in the same folder and a rename.
    fn write(&self, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        static SEQUENCE: AtomicU64 = AtomicU64::new(0);
        std::fs::create_dir_all(&self.dir)?;
        let temporary = path.with_extension(format!("tmp{}-{}", std::process::id(), SEQUENCE.fetch_add(1, Ordering::Relaxed)));
        std::fs::write(&temporary, bytes)?;
        std::fs::rename(&temporary, path).inspect_err(|_| {
            let _ = std::fs::remove_file(&temporary);
        })
    }
}

/// A cached file's image, when it is a valid container made for `key`: the role's format and
/// colour space, and a full mip chain.
fn read_cached(bytes: &[u8], key: &str, role: TextureRole, what: &str) -> Result<Image, String> {
    let image = Image::from_ktx2(bytes, role.color_space(), what).map_err(|e| e.to_string())?;
    match Image::ktx2_value(bytes, KEY_METADATA) {
        Some(stored) if stored == key => {}
        Some(stored) => return Err(format!("it was made for key {stored}")),
        None => return Err("it names no cache key".to_owned()),
    }
    if Image::ktx2_value(bytes, BLOCKS_METADATA).is_none_or(|stored| stored != blocks_hash(&image)) {
        return Err("its blocks do not match the hash it was written with".to_owned());
    }
    let full_chain = 32 - image.width.max(image.height).leading_zeros();
    if image.format != role.compressed_format() || image.mip_count() != full_chain {
        return Err(format!(
            "it holds {:?} with {} levels, not {:?} with {full_chain}",
            image.format,
            image.mip_count(),
            role.compressed_format()
        ));
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder under the system's temporary directory, removed when dropped.
    struct Folder(PathBuf);
    impl Folder {
        fn new(name: &str) -> Folder {
            let dir = std::env::temp_dir().join(format!("ecs-decals-cache-{name}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            Folder(dir)
        }
    }
    impl Drop for Folder {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn texels(seed: u8) -> (u32, u32, Vec<u8>) {
        (8, 8, (0..64u32).flat_map(|i| [(i * 4) as u8 ^ seed, (i * 7) as u8, seed, 255]).collect())
    }

    #[test]
    fn second_load_hits_and_changes_miss() {
        let folder = Folder::new("hits");
        let cache = TextureCache::new(&folder.0);
        let (source, other) = (b"png bytes of one image".as_slice(), b"png bytes of an edited image".as_slice());
        let (first, outcome) = cache.load_or_compress(source, TextureRole::Color, "test", || Ok(texels(1))).unwrap();
        assert_eq!(outcome, CacheOutcome::Compressed);
        let (second, outcome) = cache.load_or_compress(source, TextureRole::Color, "test", || panic!("a hit decodes nothing")).unwrap();
        assert_eq!((outcome, &second), (CacheOutcome::Hit, &first));
        assert_eq!(second.format, TexelFormat::Bc7);

        // Another role (a setting) or an edited source is another key.
        let (_, outcome) = cache.load_or_compress(source, TextureRole::Mask, "test", || Ok(texels(1))).unwrap();
        assert_eq!(outcome, CacheOutcome::Compressed);
        let (_, outcome) = cache.load_or_compress(other, TextureRole::Color, "test", || Ok(texels(2))).unwrap();
        assert_eq!(outcome, CacheOutcome::Compressed);
        assert_eq!(std::fs::read_dir(&folder.0).unwrap().count(), 3, "one file a key, no temporary left");
    }

    #[test]
    fn truncated_and_mismatched_files_are_rebuilt() {
        let folder = Folder::new("rebuilt");
        let cache = TextureCache::new(&folder.0);
        let source = b"some image".as_slice();
        let (image, _) = cache.load_or_compress(source, TextureRole::Normal, "test", || Ok(texels(3))).unwrap();
        let path = cache.path(&TextureCache::key(source, TextureRole::Normal));
        let bytes = std::fs::read(&path).unwrap();

        std::fs::write(&path, &bytes[..bytes.len() - 9]).unwrap();
        let (rebuilt, outcome) = cache.load_or_compress(source, TextureRole::Normal, "test", || Ok(texels(3))).unwrap();
        assert!(matches!(outcome, CacheOutcome::Rebuilt(_)), "{outcome:?}");
        assert_eq!(rebuilt, image);
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "the file was rewritten whole");

        // One flipped byte in the last level's blocks: the container is valid, its hash is not.
        let mut flipped = bytes.clone();
        *flipped.last_mut().unwrap() ^= 0x40;
        std::fs::write(&path, &flipped).unwrap();
        let (_, outcome) = cache.load_or_compress(source, TextureRole::Normal, "test", || Ok(texels(3))).unwrap();
        assert!(matches!(&outcome, CacheOutcome::Rebuilt(reason) if reason.contains("hash")), "{outcome:?}");

        // A valid container made for another key (another image's file copied over this one).
        let other = b"another image".as_slice();
        cache.load_or_compress(other, TextureRole::Normal, "test", || Ok(texels(4))).unwrap();
        std::fs::copy(cache.path(&TextureCache::key(other, TextureRole::Normal)), &path).unwrap();
        let (again, outcome) = cache.load_or_compress(source, TextureRole::Normal, "test", || Ok(texels(3))).unwrap();
        assert!(matches!(&outcome, CacheOutcome::Rebuilt(reason) if reason.contains("made for key")), "{outcome:?}");
        assert_eq!(again, image);
        let (_, outcome) = cache.load_or_compress(source, TextureRole::Normal, "test", || panic!("now it hits")).unwrap();
        assert_eq!(outcome, CacheOutcome::Hit);
    }

    #[test]
    fn an_unwritable_cache_still_compresses() {
        let folder = Folder::new("unwritable");
        std::fs::write(&folder.0, b"a file where the folder should be").unwrap();
        let cache = TextureCache::new(folder.0.join("textures"));
        let (image, outcome) = cache.load_or_compress(b"x", TextureRole::Data, "test", || Ok(texels(5))).unwrap();
        assert_eq!((outcome, image.format), (CacheOutcome::Compressed, TexelFormat::Bc7));
        let _ = std::fs::remove_file(&folder.0);
    }
}
