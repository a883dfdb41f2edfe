//! `EXT_meshopt_compression`: buffer views stored compressed by meshoptimizer's codecs (the
//! vertex codec for attributes, the index codecs for triangles and index sequences, then an
//! optional filter: octahedral normals, quaternions, exponential floats), as `gltfpack` and
//! other web-oriented exporters write them. Each compressed view is decoded, with the `meshopt`
//! crate's build of meshoptimizer, into the place its uncompressed view names (in a fallback
//! buffer, which has no data of its own, or in a buffer that also holds an uncompressed copy),
//! before any accessor is read: the rest of the loader never knows.
//!
//! The `meshopt` crate wraps the vertex and triangle decoders but not the index-sequence decoder
//! or the filters, so this module calls meshoptimizer's C functions itself: the one module of
//! the loader allowed `unsafe`. Every call is preceded by the checks that make it sound
//! (meshoptimizer asserts them, which would abort the process): sizes within the slices passed,
//! strides and counts the codec and filter accept, and output memory aligned for the widest
//! value the decoder writes.

#![allow(unsafe_code)]

use std::path::Path;

use ::gltf::Document;
use ::gltf::json::Value;
use meshopt::ffi;

use super::GltfError;

/// The extension's name.
pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

/// Whether `buffer` is one of the extension's fallback buffers: it has no data of its own, its
/// views are all decoded from compressed ones.
pub(super) fn is_fallback(buffer: &::gltf::Buffer) -> bool {
    buffer.extension_value(EXTENSION).and_then(|e| e.get("fallback")).and_then(Value::as_bool) == Some(true)
}

/// How a view was compressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

/// The filter applied after decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
}

/// One compressed view as its extension object describes it.
#[derive(Clone, Copy, Debug)]
struct Compressed {
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

impl Compressed {
    fn parse(e: &Value) -> Result<Self, String> {
        let number = |key: &str, default: Option<usize>| match e.get(key) {
            Some(v) => v.as_u64().and_then(|n| usize::try_from(n).ok()).ok_or_else(|| format!("its {key} is not a count")),
            None => default.ok_or_else(|| format!("it has no {key}")),
        };
        let mode = match e.get("mode").and_then(Value::as_str) {
            Some("ATTRIBUTES") => Mode::Attributes,
            Some("TRIANGLES") => Mode::Triangles,
            Some("INDICES") => Mode::Indices,
            other => return Err(format!("its mode {other:?} is not ATTRIBUTES, TRIANGLES or INDICES")),
        };
        let filter = match e.get("filter").map(Value::as_str) {
            None | Some(Some("NONE")) => Filter::None,
            Some(Some("OCTAHEDRAL")) => Filter::Octahedral,
            Some(Some("QUATERNION")) => Filter::Quaternion,
            Some(Some("EXPONENTIAL")) => Filter::Exponential,
            Some(other) => return Err(format!("its filter {other:?} is not NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL")),
        };
        Ok(Self {
            buffer: number("buffer", None)?,
            offset: number("byteOffset", Some(0))?,
            length: number("byteLength", None)?,
            stride: number("byteStride", None)?,
            count: number("count", None)?,
            mode,
            filter,
        })
    }

    /// The extension's rules on strides, counts and filters, which meshoptimizer asserts.
    fn check(&self) -> Result<(), String> {
        let Self { stride, count, mode, filter, .. } = *self;
        match mode {
            Mode::Attributes if stride == 0 || stride > 256 || !stride.is_multiple_of(4) => {
                Err(format!("attributes need a byteStride that is a multiple of 4 up to 256, not {stride}"))
            }
            Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
                Err(format!("indices need a byteStride of 2 or 4, not {stride}"))
            }
            Mode::Triangles if !count.is_multiple_of(3) => Err(format!("triangles need a count that is a multiple of 3, not {count}")),
            Mode::Triangles | Mode::Indices if filter != Filter::None => Err(format!("indices take no filter ({filter:?} given)")),
            _ => match filter {
                Filter::Octahedral if stride != 4 && stride != 8 => {
                    Err(format!("the octahedral filter needs a byteStride of 4 or 8, not {stride}"))
                }
                Filter::Quaternion if stride != 8 => Err(format!("the quaternion filter needs a byteStride of 8, not {stride}")),
                _ => Ok(()),
            },
        }
    }

    /// Decodes `data` (this view's compressed bytes) into `count × stride` bytes.
    fn decode(&self, data: &[u8]) -> Result<Vec<u8>, String> {
        self.check()?;
        let Self { stride, count, .. } = *self;
        let bytes = count.checked_mul(stride).ok_or("its count × byteStride overflows")?;
        // Words, not bytes: the index decoders and the filters write 16- and 32-bit values.
        let mut out = vec![0u32; bytes.div_ceil(4)];
        let destination = out.as_mut_ptr().cast::<std::ffi::c_void>();
        // SAFETY: `destination` holds at least `count × stride` bytes, aligned for u32; the
        // decoders write at most that many and read at most `data.len()` bytes from `data`; the
        // stride and count rules they assert were checked above.
        let status = unsafe {
            match self.mode {
                Mode::Attributes => ffi::meshopt_decodeVertexBuffer(destination, count, stride, data.as_ptr(), data.len()),
                Mode::Triangles => ffi::meshopt_decodeIndexBuffer(destination, count, stride, data.as_ptr(), data.len()),
                Mode::Indices => ffi::meshopt_decodeIndexSequence(destination, count, stride, data.as_ptr(), data.len()),
            }
        };
        if status != 0 {
            return Err(format!("its {:?} data does not decode (meshoptimizer's error {status})", self.mode));
        }
        // SAFETY: as above, the filters rewrite `count × stride` bytes in place, and the stride
        // each asserts was checked.
        unsafe {
            match self.filter {
                Filter::None => {}
                Filter::Octahedral => ffi::meshopt_decodeFilterOct(destination, count, stride),
                Filter::Quaternion => ffi::meshopt_decodeFilterQuat(destination, count, stride),
                Filter::Exponential => ffi::meshopt_decodeFilterExp(destination, count, stride),
            }
        }
        let mut decoded: Vec<u8> = bytemuck::cast_slice(&out).to_vec();
        decoded.truncate(bytes);
        Ok(decoded)
    }
}

/// Decodes every compressed buffer view of `document` into its place in `buffers`. Fallback
/// buffers come empty from the loader and grow to hold the views decoded into them, so what is
/// allocated follows the compressed bytes present, never a length the file merely declares. A
/// view that cannot be decoded is an error naming it.
pub(super) fn decode_views(document: &Document, buffers: &mut [Vec<u8>], file: &Path) -> Result<(), GltfError> {
    let fallback: Vec<bool> = document.buffers().map(|b| is_fallback(&b)).collect();
    for view in document.views() {
        let Some(extension) = view.extension_value(EXTENSION) else { continue };
        let bad =
            |reason: String| GltfError::BadBuffer { buffer: format!("view #{} ({EXTENSION}) of {}", view.index(), file.display()), reason };
        let compressed = Compressed::parse(extension).map_err(bad)?;
        let source = buffers
            .get(compressed.buffer)
            .and_then(|b| b.get(compressed.offset..compressed.offset.checked_add(compressed.length)?))
            .ok_or_else(|| bad(format!("its compressed bytes lie outside buffer {}", compressed.buffer)))?;
        let decoded_length = compressed.count.checked_mul(compressed.stride);
        if decoded_length != Some(view.length()) {
            return Err(bad(format!("its count × byteStride is not the {} bytes its view holds", view.length())));
        }
        // The codecs expand data by a bounded factor: a larger claim is a broken file, refused
        // before anything is allocated for it.
        let expansion = if compressed.mode == Mode::Attributes { 1024 } else { 64 };
        if view.length() > compressed.length.saturating_mul(expansion) {
            return Err(bad(format!("{} compressed bytes cannot decode to {}", compressed.length, view.length())));
        }
        let (target, end) = (view.buffer().index(), view.offset().checked_add(view.length()));
        let declared = document.buffers().nth(target).map_or(0, |b| b.length());
        let end = end.filter(|&end| end <= declared).ok_or_else(|| bad(format!("its place lies outside buffer {target}")))?;
        let decoded = compressed.decode(source).map_err(bad)?;
        let buffer = &mut buffers[target];
        if fallback[target] && buffer.len() < end {
            buffer.resize(end, 0);
        }
        let place = buffer.get_mut(view.offset()..end).ok_or_else(|| bad(format!("its place lies outside buffer {target}")))?;
        place.copy_from_slice(&decoded);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::{glb_container, load_slice};
    use super::*;

    /// A grid of `n × n` vertices and its triangles.
    fn grid(n: u32) -> (Vec<[f32; 3]>, Vec<u32>) {
        let positions = (0..n * n).map(|i| [(i % n) as f32 * 0.25, ((i / n) as f32 * 0.5).sin(), (i / n) as f32 * 0.25]).collect();
        let mut indices = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = y * n + x;
                indices.extend([i, i + n, i + 1, i + 1, i + n, i + n + 1]);
            }
        }
        (positions, indices)
    }

    /// The grid as a GLB: uncompressed, or with both views compressed into buffer 0 (the BIN
    /// chunk) and decoded into a fallback buffer 1; `corrupt` damages the compressed vertices;
    /// `claim` declares that many vertices (in the view and the fallback buffer) instead.
    fn grid_glb(compressed: bool, corrupt: bool, claim: Option<usize>) -> Vec<u8> {
        let (positions, indices) = grid(12);
        let raw_positions: &[u8] = bytemuck::cast_slice(&positions);
        let raw_indices: &[u8] = bytemuck::cast_slice(&indices);
        let (vertex_count, index_count) = (positions.len(), indices.len());
        let raw_length = raw_positions.len() + raw_indices.len();
        let accessors = format!(
            r#""accessors":[{{"bufferView":0,"componentType":5126,"count":{vertex_count},"type":"VEC3","min":[0,-1,0],"max":[3,1,3]}},
                           {{"bufferView":1,"componentType":5125,"count":{index_count},"type":"SCALAR"}}],
              "meshes":[{{"name":"Grid","primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
              "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0"#
        );
        if !compressed {
            let json = format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{raw_length}}}],
                  "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{}}},{{"buffer":0,"byteOffset":{},"byteLength":{}}}],
                  {accessors}}}"#,
                raw_positions.len(),
                raw_positions.len(),
                raw_indices.len()
            );
            return glb_container(json.as_bytes(), &[raw_positions, raw_indices].concat());
        }
        let claimed = claim.unwrap_or(vertex_count);
        let (claimed_bytes, fallback_length) = (claimed * 12, claimed * 12 + raw_indices.len());
        let mut vertices = meshopt::encode_vertex_buffer(&positions).unwrap();
        if corrupt {
            vertices.truncate(vertices.len() / 2);
        }
        let triangles = meshopt::encode_index_buffer(&indices, vertex_count).unwrap();
        let mut bin = vertices.clone();
        bin.resize(bin.len().next_multiple_of(4), 0);
        let triangles_at = bin.len();
        bin.extend(&triangles);
        bin.resize(bin.len().next_multiple_of(4), 0);
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["{EXTENSION}"],"extensionsRequired":["{EXTENSION}"],
              "buffers":[{{"byteLength":{}}},{{"byteLength":{fallback_length},"extensions":{{"{EXTENSION}":{{"fallback":true}}}}}}],
              "bufferViews":[
                {{"buffer":1,"byteOffset":0,"byteLength":{claimed_bytes},"byteStride":12,"extensions":{{"{EXTENSION}":
                  {{"buffer":0,"byteOffset":0,"byteLength":{},"byteStride":12,"count":{claimed},"mode":"ATTRIBUTES"}}}}}},
                {{"buffer":1,"byteOffset":{},"byteLength":{},"extensions":{{"{EXTENSION}":
                  {{"buffer":0,"byteOffset":{triangles_at},"byteLength":{},"byteStride":4,"count":{index_count},"mode":"TRIANGLES"}}}}}}],
              {accessors}}}"#,
            bin.len(),
            vertices.len(),
            raw_positions.len(),
            raw_indices.len(),
            triangles.len()
        );
        glb_container(json.as_bytes(), &bin)
    }

    #[test]
    fn a_meshopt_compressed_mesh_loads_as_its_uncompressed_original() {
        let plain = load_slice(&grid_glb(false, false, None), None).expect("the uncompressed grid loads");
        let packed = load_slice(&grid_glb(true, false, None), None).expect("the compressed grid loads");
        let (a, b) = (&plain.meshes[0][0].0, &packed.meshes[0][0].0);
        assert_eq!(b.indices, a.indices, "the triangles decode exactly");
        assert_eq!(b.positions.len(), 144);
        assert_eq!(b.positions, a.positions, "the positions decode exactly");
        assert_eq!(b.normals, a.normals, "and so do the normals computed from them");
    }

    #[test]
    fn a_damaged_compressed_view_is_an_error_naming_it() {
        let error = load_slice(&grid_glb(true, true, None), None).expect_err("damaged vertices cannot load");
        let message = error.to_string();
        assert!(message.contains("view #0 (EXT_meshopt_compression)") && message.contains("does not decode"), "{message}");
    }

    #[test]
    fn a_view_claiming_more_than_its_bytes_can_decode_to_is_refused_before_allocating() {
        // 2^40 vertices (12 TiB) from a few hundred compressed bytes: refused, not allocated.
        let error = load_slice(&grid_glb(true, false, Some(1 << 40)), None).expect_err("an impossible claim");
        let message = error.to_string();
        assert!(message.contains("view #0") && message.contains("cannot decode to"), "{message}");
    }

    #[test]
    fn strides_and_filters_meshoptimizer_would_abort_on_are_errors() {
        let view = |mode: Mode, stride: usize, count: usize, filter: Filter| Compressed {
            buffer: 0,
            offset: 0,
            length: 0,
            stride,
            count,
            mode,
            filter,
        };
        for (bad, what) in [
            (view(Mode::Attributes, 6, 1, Filter::None), "multiple of 4"),
            (view(Mode::Attributes, 260, 1, Filter::None), "multiple of 4"),
            (view(Mode::Triangles, 4, 4, Filter::None), "multiple of 3"),
            (view(Mode::Indices, 8, 3, Filter::None), "2 or 4"),
            (view(Mode::Triangles, 2, 3, Filter::Octahedral), "no filter"),
            (view(Mode::Attributes, 12, 1, Filter::Octahedral), "4 or 8"),
            (view(Mode::Attributes, 4, 1, Filter::Quaternion), "of 8"),
        ] {
            let reason = bad.decode(&[0; 64]).expect_err("refused before meshoptimizer sees it");
            assert!(reason.contains(what), "{bad:?}: {reason}");
        }
    }

    #[test]
    fn the_octahedral_filter_rebuilds_unit_normals() {
        // Two normals, octahedral-encoded as 8-bit X/Y with Z holding 1.0 (127): +Z, and the
        // unit vector (1, 0, 0) at the square's corner (X = 127, Y = 0).
        let encoded: [[i8; 4]; 2] = [[0, 0, 127, 0], [127, 0, 127, 0]];
        let data = meshopt::encode_vertex_buffer(&encoded).unwrap();
        let normals = Compressed {
            buffer: 0,
            offset: 0,
            length: data.len(),
            stride: 4,
            count: 2,
            mode: Mode::Attributes,
            filter: Filter::Octahedral,
        }
        .decode(&data)
        .expect("decodes");
        let n: Vec<i8> = normals.iter().map(|&b| b as i8).collect();
        assert_eq!(&n[0..3], &[0, 0, 127], "+Z stays +Z");
        assert_eq!(&n[4..7], &[127, 0, 0], "(127, 0) unfolds to +X");
    }
}
