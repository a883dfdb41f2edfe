//! Property-based fuzzing of the asset loaders: mutated glTF/GLB files go to
//! `engine::gltf::load_slice` and `engine::gltf::load`, mutated PNG/JPEG files to
//! `engine::image::Image::from_encoded`, and every property is the same: the loader returns `Ok`
//! or `Err`, never panics (proptest turns a panic into a failure and shrinks the input to a
//! minimal one, which it prints). Memory is bounded by the loaders' own limits
//! (`engine::image::MAX_DECODE_BYTES`, `engine::gltf::MAX_UNBACKED_COMPONENTS`, and accessors
//! checked against the bytes present before anything is allocated); a regression there shows up
//! here as an allocation failure, which aborts the test.
//!
//! The inputs are the shared models (`../shared/assets/gltf`, whose absence fails these tests):
//! DamagedHelmet's GLB reduced to its mesh (its 2048² textures would make every case slow) and
//! Suzanne's `.gltf` with its external `.bin` (written to a temporary directory per case), both
//! mutated at the JSON level (accessor `byteOffset`/`count`/`componentType`/`type`, buffer view
//! `byteOffset`/`byteLength`/`byteStride`/`buffer`, buffer `byteLength` set to bogus or huge
//! values, index accessors pushed past their view's end, node `children` made cyclic or chains
//! thousands deep) and at the byte level (truncation, flipped bytes, index values rewritten past
//! the vertex count); small PNG and JPEG images encoded here in every colour type (truncated,
//! flipped, or with an absurd size in a header whose CRC is fixed up); and, with few cases, one
//! real PNG and one real JPEG texture truncated or flipped. The Fox and RobotExpressive (skins,
//! clips, morph targets) get those mutations and more of their own (joint lists cut or given the
//! skinned node, interpolations changed, samplers and morph targets pointed at other accessors,
//! channels retargeted, NaN, infinite, zero and denormal floats written into float accessors):
//! what loads names the file in each of its faults and plays a clip with finite poses.
//!
//! By default the glTF properties run 32 cases each (the rigs 24), the small images 64 and the real textures 4:
//! about 2 s for the whole file in a debug build. To run longer, set `PROPTEST_CASES`, which
//! replaces every property's count (1000 cases take about 3 minutes in a debug build):
//!
//! ```sh
//! PROPTEST_CASES=10000 cargo test -p tests --test fuzz --release
//! ```
//!
//! The random seed is fixed, so a run is reproducible; `PROPTEST_RNG_SEED=<u64>` explores other
//! inputs.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use bevy_ecs::world::World;
use engine::gltf::{GltfError, GltfScene, glb_container as glb};
use engine::image::{ColorSpace, Image};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use serde_json::Value;
use tests::gltf_files::{Model, split_glb, strip_materials};

/// The configuration of a property: `cases` unless `PROPTEST_CASES` says otherwise, a fixed seed
/// unless `PROPTEST_RNG_SEED` says otherwise, and no regression files written into the tree.
fn config(cases: u32) -> ProptestConfig {
    let base = ProptestConfig::default();
    let env_cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok());
    let rng_seed = if std::env::var_os("PROPTEST_RNG_SEED").is_some() { base.rng_seed } else { RngSeed::Fixed(0x5eed_dec0) };
    ProptestConfig { cases: env_cases.unwrap_or(cases), rng_seed, failure_persistence: None, max_shrink_iters: 512, ..base }
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("cannot read shared model file {}: {e}", path.display()))
}

// ---------------------------------------------------------------------------------------------
// The models.

/// DamagedHelmet without its textures: the JSON with the image views dropped, and the BIN cut to
/// the mesh data in front of them.
fn helmet() -> &'static Model {
    static MODEL: OnceLock<Model> = OnceLock::new();
    MODEL.get_or_init(|| {
        let bytes = read(&tests::shared_gltf_dir().join("DamagedHelmet/DamagedHelmet.glb"));
        let (json, bin) = split_glb(&bytes);
        let mut json: Value = serde_json::from_slice(&json).unwrap();
        strip_materials(&mut json);
        let mesh_views: Vec<usize> =
            json["accessors"].as_array().unwrap().iter().map(|a| a["bufferView"].as_u64().unwrap() as usize).collect();
        let views = json["bufferViews"].as_array_mut().unwrap();
        assert!(mesh_views.iter().all(|&v| v < 4), "the helmet's accessors use views 0 to 3 only");
        views.truncate(4);
        let end = views.iter().map(|v| v["byteOffset"].as_u64().unwrap() + v["byteLength"].as_u64().unwrap()).max().unwrap();
        json["buffers"][0]["byteLength"] = end.into();
        Model { json, bin: bin[..end as usize].to_vec() }
    })
}

/// Suzanne without her textures, and her `.bin`.
fn suzanne() -> &'static Model {
    static MODEL: OnceLock<Model> = OnceLock::new();
    MODEL.get_or_init(|| {
        let dir = tests::shared_gltf_dir().join("Suzanne");
        let mut json: Value = serde_json::from_slice(&read(&dir.join("Suzanne.gltf"))).unwrap();
        strip_materials(&mut json);
        json["buffers"][0]["uri"] = "fuzzed.bin".into();
        Model { json, bin: read(&dir.join("Suzanne.bin")) }
    })
}

#[test]
fn the_unmutated_models_load() {
    let helmet = helmet();
    let scene = engine::gltf::load_slice(&glb(helmet.json.to_string().as_bytes(), &helmet.bin), None).unwrap();
    assert_eq!(scene.triangle_count(), 46356 / 3);
    let dir = TempDir::new("unmutated");
    let scene = load_external(&dir, suzanne()).unwrap();
    assert_eq!(scene.triangle_count(), 11808 / 3);
}

// ---------------------------------------------------------------------------------------------
// Mutations.

/// A JSON number as glTF files might hold it: small, plausible, at 32-bit edges, or absurd.
fn bogus_number() -> impl Strategy<Value = u64> {
    prop_oneof![
        0u64..16,
        0u64..1_000_000,
        Just(1 << 31),
        Just((1 << 32) - 1),
        Just(1 << 32),
        Just(1 << 53),
        Just(u64::MAX >> 1),
        Just(u64::MAX),
        any::<u64>(),
    ]
}

#[derive(Clone, Copy, Debug)]
enum AccessorField {
    ByteOffset,
    Count,
    BufferView,
    ComponentType,
    Type,
}

#[derive(Clone, Copy, Debug)]
enum ViewField {
    ByteOffset,
    ByteLength,
    ByteStride,
    Buffer,
}

/// One change to a document or its buffer.
#[derive(Clone, Debug)]
enum Mutation {
    /// Sets a field of accessor `index` (modulo the count).
    Accessor { index: usize, field: AccessorField, value: u64 },
    /// Sets a field of buffer view `index` (modulo the count).
    View { index: usize, field: ViewField, value: u64 },
    /// Sets the buffer's `byteLength`.
    BufferLength(u64),
    /// Moves the first primitive's index accessor past the end of its view: by raising its
    /// count by `by + 1`, or by starting it `by` bytes before the view's end.
    IndicesPastEnd { by: u64, via_offset: bool },
    /// Adds `to` to node `from`'s children (adding empty nodes as needed): cycles, self-loops
    /// and second parents.
    Child { from: usize, to: usize },
    /// Appends a chain of `depth` nodes below node 0, closed into a cycle if `cyclic`.
    Chain { depth: usize, cyclic: bool },
    /// Overwrites index `at` (modulo the count) of the first primitive with `value`.
    IndexValue { at: usize, value: u32 },
    /// XORs the buffer byte at `at` (modulo its length) with `mask`.
    FlipBin { at: usize, mask: u8 },
    /// Cuts the buffer to `keep` (a fraction of 2^16) of its length.
    TruncateBin { keep: u16 },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let accessor_field = prop_oneof![
        Just(AccessorField::ByteOffset),
        Just(AccessorField::Count),
        Just(AccessorField::BufferView),
        Just(AccessorField::ComponentType),
        Just(AccessorField::Type),
    ];
    let view_field =
        prop_oneof![Just(ViewField::ByteOffset), Just(ViewField::ByteLength), Just(ViewField::ByteStride), Just(ViewField::Buffer)];
    prop_oneof![
        3 => (any::<usize>(), accessor_field, bogus_number()).prop_map(|(index, field, value)| Mutation::Accessor { index, field, value }),
        3 => (any::<usize>(), view_field, bogus_number()).prop_map(|(index, field, value)| Mutation::View { index, field, value }),
        1 => bogus_number().prop_map(Mutation::BufferLength),
        2 => (prop_oneof![0u64..64, bogus_number()], any::<bool>()).prop_map(|(by, via_offset)| Mutation::IndicesPastEnd { by, via_offset }),
        2 => (0usize..6, 0usize..6).prop_map(|(from, to)| Mutation::Child { from, to }),
        1 => (1000usize..5000, any::<bool>()).prop_map(|(depth, cyclic)| Mutation::Chain { depth, cyclic }),
        2 => (any::<usize>(), prop_oneof![any::<u32>(), 0u32..20_000, Just(u32::MAX)]).prop_map(|(at, value)| Mutation::IndexValue { at, value }),
        3 => (any::<usize>(), 1u8..=255).prop_map(|(at, mask)| Mutation::FlipBin { at, mask }),
        1 => any::<u16>().prop_map(|keep| Mutation::TruncateBin { keep }),
    ]
}

/// `json[key]` as a mutable array, created (or replaced) if it is not one.
fn array<'a>(json: &'a mut Value, key: &str) -> &'a mut Vec<Value> {
    if !json[key].is_array() {
        json[key] = Value::Array(Vec::new());
    }
    json[key].as_array_mut().unwrap()
}

/// The first primitive's index accessor (Suzanne's and the helmet's are accessor 0, on view 0).
fn index_accessor(json: &Value) -> Option<usize> {
    json["meshes"][0]["primitives"][0]["indices"].as_u64().map(|i| i as usize)
}

fn apply(model: &mut Model, mutation: &Mutation) {
    let json = &mut model.json;
    match *mutation {
        Mutation::Accessor { index, field, value } => {
            let accessors = array(json, "accessors");
            if accessors.is_empty() {
                return;
            }
            let len = accessors.len();
            let accessor = &mut accessors[index % len];
            match field {
                AccessorField::ByteOffset => accessor["byteOffset"] = value.into(),
                AccessorField::Count => accessor["count"] = value.into(),
                AccessorField::BufferView => accessor["bufferView"] = value.into(),
                // Mostly the valid types, sometimes not.
                AccessorField::ComponentType => {
                    accessor["componentType"] =
                        [5120, 5121, 5122, 5123, 5125, 5126, value].get(value as usize % 8).copied().unwrap_or(5126).into()
                }
                AccessorField::Type => {
                    accessor["type"] = ["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "VEC5"][value as usize % 8].into()
                }
            }
        }
        Mutation::View { index, field, value } => {
            let views = array(json, "bufferViews");
            if views.is_empty() {
                return;
            }
            let len = views.len();
            let view = &mut views[index % len];
            let key = match field {
                ViewField::ByteOffset => "byteOffset",
                ViewField::ByteLength => "byteLength",
                ViewField::ByteStride => "byteStride",
                ViewField::Buffer => "buffer",
            };
            view[key] = value.into();
        }
        Mutation::BufferLength(value) => json["buffers"][0]["byteLength"] = value.into(),
        Mutation::IndicesPastEnd { by, via_offset } => {
            let Some(index) = index_accessor(json) else { return };
            let view = json["accessors"][index]["bufferView"].as_u64().unwrap_or(0) as usize;
            let view_length = json["bufferViews"][view]["byteLength"].as_u64().unwrap_or(0);
            let accessor = &mut json["accessors"][index];
            if via_offset {
                accessor["byteOffset"] = view_length.saturating_sub(by).into();
            } else {
                let count = accessor["count"].as_u64().unwrap_or(0);
                accessor["count"] = count.saturating_add(by).saturating_add(1).into();
            }
        }
        Mutation::Child { from, to } => {
            let nodes = array(json, "nodes");
            while nodes.len() <= from.max(to) {
                nodes.push(serde_json::json!({}));
            }
            array(&mut nodes[from], "children").push(to.into());
        }
        Mutation::Chain { depth, cyclic } => {
            let nodes = array(json, "nodes");
            if nodes.is_empty() {
                nodes.push(serde_json::json!({}));
            }
            let first = nodes.len();
            for i in 0..depth {
                let next = if i + 1 < depth {
                    Some(first + i + 1)
                } else if cyclic {
                    Some(first)
                } else {
                    None
                };
                nodes.push(match next {
                    Some(next) => serde_json::json!({ "children": [next] }),
                    None => serde_json::json!({}),
                });
            }
            array(&mut nodes[0], "children").push(first.into());
        }
        Mutation::IndexValue { at, value } => {
            // Both models keep u16 indices at the start of the buffer.
            let declared = index_accessor(json).and_then(|i| json["accessors"][i]["count"].as_u64()).unwrap_or(0);
            let count = (model.bin.len() / 2).min(usize::try_from(declared).unwrap_or(usize::MAX));
            if count > 0 {
                let at = (at % count) * 2;
                model.bin[at..at + 2].copy_from_slice(&(value as u16).to_le_bytes());
            }
        }
        Mutation::FlipBin { at, mask } => {
            if !model.bin.is_empty() {
                let len = model.bin.len();
                model.bin[at % len] ^= mask;
            }
        }
        Mutation::TruncateBin { keep } => {
            let keep = (model.bin.len() * keep as usize) >> 16;
            model.bin.truncate(keep);
        }
    }
}

fn mutated(model: &Model, mutations: &[Mutation]) -> Model {
    let mut model = model.clone();
    for mutation in mutations {
        apply(&mut model, mutation);
    }
    model
}

/// Spawns what loaded; an error must name the file (`what`) and say something.
fn check(result: Result<GltfScene, GltfError>, what: &str) {
    match result {
        Ok(scene) => {
            let mut world = World::new();
            scene.spawn(&mut world);
        }
        Err(error) => {
            let message = error.to_string();
            assert!(message.contains(what), "the error names {what}: {message}");
        }
    }
}

/// A directory under the system's temporary directory, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("ecs-decals-fuzz-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.0).ok();
    }
}

/// Writes the model as `fuzzed.gltf` + `fuzzed.bin` and loads it from the file.
fn load_external(dir: &TempDir, model: &Model) -> Result<GltfScene, GltfError> {
    std::fs::write(dir.0.join("fuzzed.bin"), &model.bin).unwrap();
    let path = dir.0.join("fuzzed.gltf");
    std::fs::write(&path, model.json.to_string()).unwrap();
    engine::gltf::load(&path)
}

// ---------------------------------------------------------------------------------------------
// glTF properties.

proptest! {
    #![proptest_config(config(32))]

    /// DamagedHelmet's mesh as a GLB in memory, with JSON- and buffer-level mutations.
    #[test]
    fn mutated_glb_loads_or_fails_cleanly(mutations in prop::collection::vec(mutation(), 1..5)) {
        let model = mutated(helmet(), &mutations);
        check(engine::gltf::load_slice(&glb(model.json.to_string().as_bytes(), &model.bin), None), "<memory>");
    }

    /// Suzanne as `.gltf` + external `.bin` files, with JSON- and buffer-level mutations.
    #[test]
    fn mutated_gltf_files_load_or_fail_cleanly(mutations in prop::collection::vec(mutation(), 1..5)) {
        let dir = TempDir::new("suzanne");
        check(load_external(&dir, &mutated(suzanne(), &mutations)), "fuzzed");
    }

    /// The helmet's GLB bytes themselves: truncated (headers left as they are, or fixed up to the
    /// new length so that parsing gets as far as the cut), and with flipped bytes anywhere, more
    /// often in the headers and the JSON.
    #[test]
    fn damaged_glb_bytes_load_or_fail_cleanly(
        keep in prop::option::of(any::<u16>()),
        fix_lengths in any::<bool>(),
        flips in prop::collection::vec((prop_oneof![0usize..32, 0usize..4096, any::<usize>()], 1u8..=255), 0..8),
    ) {
        let helmet = helmet();
        let mut bytes = glb(helmet.json.to_string().as_bytes(), &helmet.bin);
        if let Some(keep) = keep {
            let len = (bytes.len() * keep as usize) >> 16;
            bytes.truncate(len);
            if fix_lengths && len >= 20 {
                let total = len as u32;
                bytes[8..12].copy_from_slice(&total.to_le_bytes());
                let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
                let bin_header = 20 + json_len;
                if len >= bin_header + 8 {
                    bytes[bin_header..bin_header + 4].copy_from_slice(&((len - bin_header - 8) as u32).to_le_bytes());
                }
            }
        }
        for (at, mask) in flips {
            if !bytes.is_empty() {
                let len = bytes.len();
                bytes[at % len] ^= mask;
            }
        }
        check(engine::gltf::load_slice(&bytes, None), "<memory>");
    }
}

// ---------------------------------------------------------------------------------------------
// Skins, animations and morph targets: the Fox (one skin, three clips) and RobotExpressive (two
// skins, morph targets, fourteen clips).

/// One change to a rigged model's skins, clips or morph targets.
#[derive(Clone, Debug)]
enum RigMutation {
    /// A mutation of the accessors, views, nodes or buffer above.
    Plain(Mutation),
    /// Keeps the first `keep` joints of a skin.
    TruncateJoints { skin: usize, keep: usize },
    /// Appends a joint to a skin: node `node`, or (`None`) the first node that skin deforms.
    AddJoint { skin: usize, node: Option<usize> },
    /// Sets a sampler's interpolation (0 step, 1 linear, 2 cubic spline).
    Interpolation { animation: usize, sampler: usize, which: u8 },
    /// Points a sampler's input (times) or output (values) at another accessor.
    SamplerAccessor { animation: usize, sampler: usize, output: bool, accessor: usize },
    /// Retargets a channel to another node and property (0 translation, 1 rotation, 2 scale, 3 weights).
    Retarget { animation: usize, channel: usize, node: usize, path: u8 },
    /// Points a morph target's POSITION at another accessor.
    MorphAccessor { mesh: usize, target: usize, accessor: usize },
    /// Writes a hostile float over one component of a float accessor's data.
    Poison { accessor: usize, element: usize, component: usize, value: f32 },
}

fn rig_mutation() -> impl Strategy<Value = RigMutation> {
    // Not finite, zero, denormal, or plausible. (Finite values near f32::MAX are not among them:
    // the loader passes them on, and composing transforms of them overflows.)
    let hostile =
        prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(0.0), Just(-1.0), Just(1e-40), -1e3f32..1e3];
    prop_oneof![
        2 => mutation().prop_map(RigMutation::Plain),
        1 => (any::<usize>(), 0usize..30).prop_map(|(skin, keep)| RigMutation::TruncateJoints { skin, keep }),
        1 => (any::<usize>(), prop::option::of(0usize..80)).prop_map(|(skin, node)| RigMutation::AddJoint { skin, node }),
        1 => (any::<usize>(), any::<usize>(), 0u8..3).prop_map(|(animation, sampler, which)| RigMutation::Interpolation { animation, sampler, which }),
        1 => (any::<usize>(), any::<usize>(), any::<bool>(), any::<usize>())
            .prop_map(|(animation, sampler, output, accessor)| RigMutation::SamplerAccessor { animation, sampler, output, accessor }),
        1 => (any::<usize>(), any::<usize>(), 0usize..80, 0u8..4).prop_map(|(animation, channel, node, path)| RigMutation::Retarget { animation, channel, node, path }),
        1 => (any::<usize>(), any::<usize>(), any::<usize>()).prop_map(|(mesh, target, accessor)| RigMutation::MorphAccessor { mesh, target, accessor }),
        3 => (any::<usize>(), any::<usize>(), 0usize..16, hostile).prop_map(|(accessor, element, component, value)| RigMutation::Poison { accessor, element, component, value }),
    ]
}

/// Element `index` (modulo the length) of `json[key]`, if it is a non-empty array.
fn nth<'a>(json: &'a mut Value, key: &str, index: usize) -> Option<&'a mut Value> {
    let items = json.get_mut(key)?.as_array_mut().filter(|a| !a.is_empty())?;
    let len = items.len();
    items.get_mut(index % len)
}

fn apply_rig(model: &mut Model, mutation: &RigMutation) {
    let accessors = model.json["accessors"].as_array().map_or(0, Vec::len).max(1);
    match *mutation {
        RigMutation::Plain(ref plain) => apply(model, plain),
        RigMutation::TruncateJoints { skin, keep } => {
            if let Some(joints) = nth(&mut model.json, "skins", skin).and_then(|s| s["joints"].as_array_mut()) {
                joints.truncate(keep.max(1));
            }
        }
        RigMutation::AddJoint { skin, node } => {
            let skins = model.json["skins"].as_array().map_or(0, Vec::len).max(1);
            let skinned = model.json["nodes"]
                .as_array()
                .and_then(|nodes| nodes.iter().position(|n| n["skin"].as_u64() == Some((skin % skins) as u64)));
            let node_count = model.json["nodes"].as_array().map_or(0, Vec::len).max(1);
            let Some(joint) = node.map(|n| n % node_count).or(skinned) else { return };
            if let Some(joints) = nth(&mut model.json, "skins", skin).and_then(|s| s["joints"].as_array_mut()) {
                joints.push(joint.into());
            }
        }
        RigMutation::Interpolation { animation, sampler, which } => {
            if let Some(sampler) = nth(&mut model.json, "animations", animation).and_then(|a| nth(a, "samplers", sampler)) {
                sampler["interpolation"] = ["STEP", "LINEAR", "CUBICSPLINE"][which as usize % 3].into();
            }
        }
        RigMutation::SamplerAccessor { animation, sampler, output, accessor } => {
            if let Some(sampler) = nth(&mut model.json, "animations", animation).and_then(|a| nth(a, "samplers", sampler)) {
                sampler[if output { "output" } else { "input" }] = (accessor % accessors).into();
            }
        }
        RigMutation::Retarget { animation, channel, node, path } => {
            let node_count = model.json["nodes"].as_array().map_or(0, Vec::len).max(1);
            if let Some(channel) = nth(&mut model.json, "animations", animation).and_then(|a| nth(a, "channels", channel)) {
                channel["target"]["node"] = (node % node_count).into();
                channel["target"]["path"] = ["translation", "rotation", "scale", "weights"][path as usize % 4].into();
            }
        }
        RigMutation::MorphAccessor { mesh, target, accessor } => {
            let target = nth(&mut model.json, "meshes", mesh).and_then(|m| nth(m, "primitives", 0)).and_then(|p| nth(p, "targets", target));
            if let Some(target) = target {
                target["POSITION"] = (accessor % accessors).into();
            }
        }
        RigMutation::Poison { accessor, element, component, value } => {
            let Some(a) = model.json["accessors"].as_array().and_then(|a| a.get(accessor % accessors)).cloned() else { return };
            if a["componentType"].as_u64() != Some(5126) {
                return;
            }
            let Some(view) = a["bufferView"].as_u64().and_then(|v| model.json["bufferViews"].get(v as usize)).cloned() else { return };
            let components = match a["type"].as_str() {
                Some("SCALAR") => 1,
                Some("VEC2") => 2,
                Some("VEC3") => 3,
                Some("VEC4") => 4,
                Some("MAT4") => 16,
                _ => return,
            };
            let count = a["count"].as_u64().unwrap_or(0) as usize;
            if count == 0 {
                return;
            }
            let stride = view["byteStride"].as_u64().map_or(components * 4, |s| s as usize);
            let offset = view["byteOffset"].as_u64().unwrap_or(0) as usize + a["byteOffset"].as_u64().unwrap_or(0) as usize;
            let at = offset + (element % count) * stride + (component % components) * 4;
            if let Some(bytes) = model.bin.get_mut(at..at + 4) {
                bytes.copy_from_slice(&value.to_le_bytes());
            }
        }
    }
}

/// The Fox and RobotExpressive without their textures.
fn rigged(robot: bool) -> &'static Model {
    static MODELS: OnceLock<[Model; 2]> = OnceLock::new();
    &MODELS.get_or_init(|| [Model::shared("Fox"), Model::shared("RobotExpressive")])[robot as usize]
}

#[test]
fn the_unmutated_rigged_models_load_without_faults() {
    for robot in [false, true] {
        let scene = rigged(robot).load().unwrap();
        assert!(scene.faults.is_empty(), "{:?}", scene.faults);
        assert!(!scene.skins.is_empty() && !scene.animations.is_empty());
    }
}

proptest! {
    #![proptest_config(config(24))]

    /// The Fox or the robot with their skins, clips and morph targets broken: the file loads
    /// (each fault naming the file) or fails with an error naming it, never panics; what loads
    /// plays one of its clips with every pose finite.
    #[test]
    fn mutated_rigs_load_or_fail_cleanly_and_pose_finitely(
        robot in any::<bool>(),
        clip in any::<usize>(),
        mutations in prop::collection::vec(rig_mutation(), 1..5),
    ) {
        let mut model = rigged(robot).clone();
        for mutation in &mutations {
            apply_rig(&mut model, mutation);
        }
        match model.load() {
            Ok(scene) => {
                for fault in &scene.faults {
                    prop_assert!(fault.to_string().starts_with("<memory>: "), "{}", fault);
                }
                tests::gltf_files::assert_finite_poses(scene, clip, 3);
            }
            Err(error) => prop_assert!(error.to_string().contains("<memory>"), "the error names the file: {}", error),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Images.

/// The colour types the `image` crate's PNG encoder writes (all that PNG has at 8 and 16 bits).
#[derive(Clone, Copy, Debug)]
enum PngKind {
    L8,
    La8,
    Rgb8,
    Rgba8,
    L16,
    La16,
    Rgb16,
    Rgba16,
}

/// A small image to encode, and what to do to its bytes.
#[derive(Clone, Debug)]
struct ImageCase {
    width: u32,
    height: u32,
    /// `None`: JPEG, grey if `grey_jpeg`.
    png: Option<PngKind>,
    grey_jpeg: bool,
    seed: u64,
    damage: Damage,
}

#[derive(Clone, Debug)]
enum Damage {
    None,
    /// Keep this fraction (of 2^16) of the bytes.
    Truncate(u16),
    /// XOR these bytes (positions modulo the length).
    Flip(Vec<(usize, u8)>),
    /// Rewrite the declared size in the header (PNG: IHDR with its CRC fixed up; JPEG: SOF0).
    Size(u32, u32),
}

fn image_case() -> impl Strategy<Value = ImageCase> {
    let png = prop_oneof![
        Just(None),
        prop_oneof![
            Just(PngKind::L8),
            Just(PngKind::La8),
            Just(PngKind::Rgb8),
            Just(PngKind::Rgba8),
            Just(PngKind::L16),
            Just(PngKind::La16),
            Just(PngKind::Rgb16),
            Just(PngKind::Rgba16),
        ]
        .prop_map(Some),
    ];
    // Sizes that are absurd, or small: a size that is large but within the limits would decode
    // (JPEG decoders fill in missing data) and make the case slow without testing more.
    let size = prop_oneof![0u32..64, 16_385u32..=u32::MAX, Just(u32::MAX), Just(1 << 31)];
    let damage = prop_oneof![
        1 => Just(Damage::None),
        2 => any::<u16>().prop_map(Damage::Truncate),
        2 => prop::collection::vec((any::<usize>(), 1u8..=255), 1..8).prop_map(Damage::Flip),
        2 => (size.clone(), size).prop_map(|(w, h)| Damage::Size(w, h)),
    ];
    (1u32..=16, 1u32..=16, png, any::<bool>(), any::<u64>(), damage).prop_map(|(width, height, png, grey_jpeg, seed, damage)| ImageCase {
        width,
        height,
        png,
        grey_jpeg,
        seed,
        damage,
    })
}

/// Pseudo-random samples from `seed` (SplitMix64).
fn samples(seed: u64, count: usize) -> Vec<u64> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        })
        .collect()
}

/// The encoded image, and for PNG the RGBA8 texels it must decode to (grey replicated, alpha
/// 255 when absent, 16-bit samples rounded to 8 bits).
fn encode(case: &ImageCase) -> (Vec<u8>, Option<Vec<u8>>) {
    use image::{DynamicImage, ImageBuffer, ImageFormat};
    let (w, h) = (case.width, case.height);
    let n = (w * h) as usize;
    let s = samples(case.seed, n * 4);
    let wide = |i: usize, c: usize| s[i * 4 + c] as u16;
    let narrow = |i: usize, c: usize| s[i * 4 + c] as u8;
    let round = |v: u16| ((v as u32 + 128) / 257) as u8;
    let Some(kind) = case.png else {
        let image = if case.grey_jpeg {
            DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, y| image::Luma([narrow((y * w + x) as usize, 0)])))
        } else {
            DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| {
                let i = (y * w + x) as usize;
                image::Rgb([narrow(i, 0), narrow(i, 1), narrow(i, 2)])
            }))
        };
        let mut bytes = Vec::new();
        image.write_to(&mut std::io::Cursor::new(&mut bytes), ImageFormat::Jpeg).unwrap();
        return (bytes, None);
    };
    let pixel = |x: u32, y: u32| (y * w + x) as usize;
    let (image, expected): (DynamicImage, Vec<[u8; 4]>) = match kind {
        PngKind::L8 => (
            DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, y| image::Luma([narrow(pixel(x, y), 0)]))),
            (0..n).map(|i| [narrow(i, 0), narrow(i, 0), narrow(i, 0), 255]).collect(),
        ),
        PngKind::La8 => (
            DynamicImage::ImageLumaA8(ImageBuffer::from_fn(w, h, |x, y| image::LumaA([narrow(pixel(x, y), 0), narrow(pixel(x, y), 3)]))),
            (0..n).map(|i| [narrow(i, 0), narrow(i, 0), narrow(i, 0), narrow(i, 3)]).collect(),
        ),
        PngKind::Rgb8 => (
            DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| {
                let i = pixel(x, y);
                image::Rgb([narrow(i, 0), narrow(i, 1), narrow(i, 2)])
            })),
            (0..n).map(|i| [narrow(i, 0), narrow(i, 1), narrow(i, 2), 255]).collect(),
        ),
        PngKind::Rgba8 => (
            DynamicImage::ImageRgba8(ImageBuffer::from_fn(w, h, |x, y| image::Rgba(std::array::from_fn(|c| narrow(pixel(x, y), c))))),
            (0..n).map(|i| std::array::from_fn(|c| narrow(i, c))).collect(),
        ),
        PngKind::L16 => (
            DynamicImage::ImageLuma16(ImageBuffer::from_fn(w, h, |x, y| image::Luma([wide(pixel(x, y), 0)]))),
            (0..n).map(|i| [round(wide(i, 0)), round(wide(i, 0)), round(wide(i, 0)), 255]).collect(),
        ),
        PngKind::La16 => (
            DynamicImage::ImageLumaA16(ImageBuffer::from_fn(w, h, |x, y| image::LumaA([wide(pixel(x, y), 0), wide(pixel(x, y), 3)]))),
            (0..n).map(|i| [round(wide(i, 0)), round(wide(i, 0)), round(wide(i, 0)), round(wide(i, 3))]).collect(),
        ),
        PngKind::Rgb16 => (
            DynamicImage::ImageRgb16(ImageBuffer::from_fn(w, h, |x, y| {
                let i = pixel(x, y);
                image::Rgb([wide(i, 0), wide(i, 1), wide(i, 2)])
            })),
            (0..n).map(|i| [round(wide(i, 0)), round(wide(i, 1)), round(wide(i, 2)), 255]).collect(),
        ),
        PngKind::Rgba16 => (
            DynamicImage::ImageRgba16(ImageBuffer::from_fn(w, h, |x, y| image::Rgba(std::array::from_fn(|c| wide(pixel(x, y), c))))),
            (0..n).map(|i| std::array::from_fn(|c| round(wide(i, c)))).collect(),
        ),
    };
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), ImageFormat::Png).unwrap();
    (bytes, Some(expected.concat()))
}

/// CRC-32 as PNG chunks use it, bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in bytes {
        crc ^= byte as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

fn damage(bytes: &mut Vec<u8>, damage: &Damage, png: bool) {
    match damage {
        Damage::None => {}
        Damage::Truncate(keep) => bytes.truncate((bytes.len() * *keep as usize) >> 16),
        Damage::Flip(flips) => {
            let len = bytes.len();
            for &(at, mask) in flips {
                bytes[at % len] ^= mask;
            }
        }
        Damage::Size(width, height) if png => {
            // Signature (8), IHDR length (4) and type (4), then width and height; CRC at 29.
            bytes[16..20].copy_from_slice(&width.to_be_bytes());
            bytes[20..24].copy_from_slice(&height.to_be_bytes());
            let crc = crc32(&bytes[12..29]);
            bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        }
        Damage::Size(width, height) => {
            // SOF0: marker, length (2), precision (1), height (2), width (2).
            if let Some(sof) = bytes.windows(2).position(|m| m == [0xff, 0xc0]) {
                bytes[sof + 5..sof + 7].copy_from_slice(&(*height as u16).to_be_bytes());
                bytes[sof + 7..sof + 9].copy_from_slice(&(*width as u16).to_be_bytes());
            }
        }
    }
}

/// One real PNG and one real JPEG texture of the shared models: Suzanne's metallic-roughness
/// map and the helmet's smallest embedded JPEG.
fn real_textures() -> &'static [Vec<u8>; 2] {
    static TEXTURES: OnceLock<[Vec<u8>; 2]> = OnceLock::new();
    TEXTURES.get_or_init(|| {
        let dir = tests::shared_gltf_dir();
        let png = read(&dir.join("Suzanne/Suzanne_MetallicRoughness.png"));
        let bytes = read(&dir.join("DamagedHelmet/DamagedHelmet.glb"));
        let (json, bin) = split_glb(&bytes);
        let json: Value = serde_json::from_slice(&json).unwrap();
        let views = json["bufferViews"].as_array().unwrap();
        let jpeg = json["images"]
            .as_array()
            .unwrap()
            .iter()
            .map(|image| &views[image["bufferView"].as_u64().unwrap() as usize])
            .map(|view| (view["byteOffset"].as_u64().unwrap() as usize, view["byteLength"].as_u64().unwrap() as usize))
            .min_by_key(|&(_, length)| length)
            .map(|(offset, length)| bin[offset..offset + length].to_vec())
            .unwrap();
        assert!(jpeg.starts_with(&[0xff, 0xd8]), "the helmet's images are JPEG");
        [png, jpeg]
    })
}

proptest! {
    #![proptest_config(config(64))]

    /// Small PNGs of every colour type and small JPEGs, intact or damaged. Intact PNGs must
    /// decode to exactly the expected RGBA8.
    #[test]
    fn damaged_small_images_decode_or_fail_cleanly(case in image_case()) {
        let (mut bytes, expected) = encode(&case);
        damage(&mut bytes, &case.damage, case.png.is_some());
        let result = Image::from_encoded(&bytes, ColorSpace::Srgb);
        match (&case.damage, result) {
            (Damage::None, Ok(image)) => {
                prop_assert_eq!((image.width, image.height), (case.width, case.height));
                if let Some(expected) = expected {
                    prop_assert_eq!(&image.mips[0], &expected);
                }
            }
            (Damage::None, Err(error)) => prop_assert!(false, "an intact image fails: {}", error),
            (_, Ok(image)) => prop_assert_eq!(image.mips[0].len(), (image.width * image.height * 4) as usize),
            (_, Err(error)) => prop_assert!(error.to_string().contains("bytes in memory"), "{}", error),
        }
    }
}

proptest! {
    #![proptest_config(config(4))]

    /// A real PNG and a real JPEG texture, truncated or with flipped bytes.
    #[test]
    fn damaged_real_textures_decode_or_fail_cleanly(
        jpeg in any::<bool>(),
        keep in prop::option::of(any::<u16>()),
        flips in prop::collection::vec((any::<usize>(), 1u8..=255), 0..4),
    ) {
        let mut bytes = real_textures()[jpeg as usize].clone();
        if let Some(keep) = keep {
            damage(&mut bytes, &Damage::Truncate(keep), !jpeg);
        }
        if !flips.is_empty() && !bytes.is_empty() {
            damage(&mut bytes, &Damage::Flip(flips), !jpeg);
        }
        if let Ok(image) = Image::from_encoded(&bytes, ColorSpace::Linear) {
            prop_assert_eq!(image.mips[0].len(), (image.width * image.height * 4) as usize);
        }
    }
}
