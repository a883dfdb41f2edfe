//! glTF files built or taken apart by tests: a model as its JSON document and its one buffer
//! ([`Model`]), the chunks of a GLB ([`split_glb`]), a builder of small documents
//! ([`Builder`]), and [`parts_model`], a scene of one healthy part beside a skin, a clip, morph
//! targets, a light, a camera and a material, each of which a test can break on its own.

use serde_json::{Value, json};

/// A model: its JSON document and its one buffer.
#[derive(Clone, Debug)]
pub struct Model {
    /// The glTF document.
    pub json: Value,
    /// Buffer 0 (the GLB's BIN chunk).
    pub bin: Vec<u8>,
}

impl Model {
    /// The model as a GLB file's bytes.
    pub fn glb(&self) -> Vec<u8> {
        engine::gltf::glb_container(self.json.to_string().as_bytes(), &self.bin)
    }

    /// Loads the model from memory (its faults name `<memory>`).
    pub fn load(&self) -> Result<engine::gltf::GltfScene, engine::gltf::GltfError> {
        engine::gltf::load_slice(&self.glb(), None)
    }

    /// Reads a shared model's GLB (`dir/name/name.glb` under [`crate::shared_gltf_dir`]), without
    /// its materials ([`strip_materials`]). Panics when the file is missing: a test whose input
    /// is missing fails.
    pub fn shared(name: &str) -> Model {
        let path = crate::shared_gltf_dir().join(name).join(format!("{name}.glb"));
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read shared model file {}: {e}", path.display()));
        let (json, bin) = split_glb(&bytes);
        let mut json: Value = serde_json::from_slice(&json).expect("the shared model's JSON parses");
        strip_materials(&mut json);
        Model { json, bin }
    }

    /// Overwrites the little-endian `f32`s of accessor `accessor` from element `element` on
    /// (tightly packed accessors, as [`Builder`] writes them).
    pub fn write_floats(&mut self, accessor: usize, element: usize, values: &[f32]) {
        let at = self.element_offset(accessor, element, 4);
        for (i, v) in values.iter().enumerate() {
            self.bin[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
    }

    /// Overwrites the little-endian `u16`s of accessor `accessor` from element `element` on.
    pub fn write_u16s(&mut self, accessor: usize, element: usize, values: &[u16]) {
        let at = self.element_offset(accessor, element, 2);
        for (i, v) in values.iter().enumerate() {
            self.bin[at + 2 * i..at + 2 * i + 2].copy_from_slice(&v.to_le_bytes());
        }
    }

    /// Byte offset in the buffer of `element` of a tightly packed accessor of `component`-byte
    /// components.
    fn element_offset(&self, accessor: usize, element: usize, component: usize) -> usize {
        let a = &self.json["accessors"][accessor];
        let view = &self.json["bufferViews"][a["bufferView"].as_u64().expect("a buffer view") as usize];
        let components = match a["type"].as_str().expect("a type") {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            other => panic!("accessor type {other}"),
        };
        let offset = |v: &Value| v.as_u64().unwrap_or(0) as usize;
        offset(&view["byteOffset"]) + offset(&a["byteOffset"]) + element * components * component
    }
}

/// The JSON and BIN chunks of a GLB.
pub fn split_glb(bytes: &[u8]) -> (Vec<u8>, Vec<u8>) {
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at);
    (bytes[20..bin_at].to_vec(), bytes[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

/// Drops materials, textures, images and samplers, so that loads spend no time decoding images.
pub fn strip_materials(json: &mut Value) {
    let root = json.as_object_mut().unwrap();
    for key in ["materials", "textures", "images", "samplers"] {
        root.remove(key);
    }
    for mesh in root.get_mut("meshes").and_then(Value::as_array_mut).into_iter().flatten() {
        for primitive in mesh["primitives"].as_array_mut().into_iter().flatten() {
            primitive.as_object_mut().unwrap().remove("material");
        }
    }
}

/// Builds a document's accessors over one buffer: each call appends its data (4-byte aligned),
/// one buffer view and one accessor, and returns the accessor's index.
#[derive(Debug, Default)]
pub struct Builder {
    accessors: Vec<Value>,
    views: Vec<Value>,
    bin: Vec<u8>,
}

impl Builder {
    fn push(&mut self, bytes: &[u8], count: usize, accessor: Value) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.views.push(json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() }));
        self.bin.extend_from_slice(bytes);
        let mut accessor = accessor;
        accessor["bufferView"] = (self.views.len() - 1).into();
        accessor["count"] = count.into();
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Float elements of `kind` (`SCALAR`, `VEC3`, `VEC4`, `MAT4`…), `N` floats each.
    pub fn floats<const N: usize>(&mut self, kind: &str, elements: &[[f32; N]]) -> usize {
        let bytes: Vec<u8> = elements.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        let mut accessor = json!({ "componentType": 5126, "type": kind });
        if kind == "SCALAR" || kind == "VEC3" {
            // POSITION and sampler inputs must declare their bounds.
            let bound =
                |pick: fn(f32, f32) -> f32| (0..N).map(|c| elements.iter().map(|e| e[c]).fold(elements[0][c], pick)).collect::<Vec<_>>();
            accessor["min"] = bound(f32::min).into();
            accessor["max"] = bound(f32::max).into();
        }
        self.push(&bytes, elements.len(), accessor)
    }

    /// Unsigned 16-bit elements of `kind`, `N` each (joints, indices).
    pub fn u16s<const N: usize>(&mut self, kind: &str, elements: &[[u16; N]]) -> usize {
        let bytes: Vec<u8> = elements.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        self.push(&bytes, elements.len(), json!({ "componentType": 5123, "type": kind }))
    }

    /// The document `rest` (meshes, nodes, …) with these accessors, views and buffer.
    pub fn finish(self, mut rest: Value) -> Model {
        rest["asset"] = json!({ "version": "2.0" });
        rest["accessors"] = self.accessors.into();
        rest["bufferViews"] = self.views.into();
        rest["buffers"] = json!([{ "byteLength": self.bin.len() }]);
        Model { json: rest, bin: self.bin }
    }
}

/// Accessors of [`parts_model`] that tests break, by what they hold.
#[derive(Clone, Copy, Debug)]
pub struct PartsAccessors {
    /// The body's `JOINTS_0` (three `[u16; 4]`).
    pub joints: usize,
    /// The body's `WEIGHTS_0` (three `[f32; 4]`).
    pub weights: usize,
    /// The rig's inverse bind matrices (two).
    pub inverse_binds: usize,
    /// Morph target 1's position offsets (three).
    pub morph_1: usize,
    /// The arm's rotation sampler (sampler 1): its times and its quaternions.
    pub arm_times: usize,
    /// The arm's quaternions (two keyframes).
    pub arm_rotations: usize,
    /// The root's translation sampler (sampler 3): its vectors (two keyframes).
    pub root_translations: usize,
}

/// A scene of healthy and breakable parts, in node order:
///
/// - node 0 `Healthy`: a rigid triangle (mesh 0 `Healthy`, material 0 `Paint`) whose translation
///   channel 0 of clip 0 `Clip` animates; it must load intact whatever else breaks;
/// - node 1 `Body`: a triangle (mesh 1 `Body`) skinned by skin 0 `Rig` (joints: nodes 2 `Root`
///   and 3 `Arm`, Arm a child of Root; vertex 0 on the root, 1 half on each, 2 on the arm), with two
///   morph targets whose weights channel 2 animates;
/// - channel 1 rotates the arm, channel 3 moves the root;
/// - node 4 `Lamp` carries light 0 `Lamp` (a point light), node 5 `Eye` camera 0 `Eye`.
///
/// Every sampler has input and output accessors of its own.
pub fn parts_model() -> (Model, PartsAccessors) {
    let mut b = Builder::default();
    let triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let healthy_positions = b.floats("VEC3", &triangle);
    let body_positions = b.floats("VEC3", &triangle);
    let joints = b.u16s("VEC4", &[[0, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]);
    let weights = b.floats("VEC4", &[[1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]);
    let morph_0 = b.floats("VEC3", &[[0.0, 0.0, 0.5], [0.0, 0.0, 0.5], [0.0, 0.0, 0.5]]);
    let morph_1 = b.floats("VEC3", &[[0.1, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.0, 0.0]]);
    let identity = glam::Mat4::IDENTITY.to_cols_array();
    let inverse_binds = b.floats("MAT4", &[identity, identity]);
    let times = |b: &mut Builder| b.floats("SCALAR", &[[0.0], [1.0]]);
    let (t0, t1, t2, t3) = (times(&mut b), times(&mut b), times(&mut b), times(&mut b));
    let healthy_translations = b.floats("VEC3", &[[0.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
    let half_turn = glam::Quat::from_rotation_z(1.0).to_array();
    let arm_rotations = b.floats("VEC4", &[[0.0, 0.0, 0.0, 1.0], half_turn]);
    let morph_weights = b.floats("SCALAR", &[[0.0], [0.0], [1.0], [0.5]]);
    let root_translations = b.floats("VEC3", &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    let model = b.finish(json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [{ "name": "Lamp", "type": "point", "intensity": 5.0, "color": [1.0, 0.9, 0.8] }] } },
        "materials": [{ "name": "Paint", "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.2, 0.2, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6 } }],
        "cameras": [{ "name": "Eye", "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }],
        "meshes": [
            { "name": "Healthy", "primitives": [{ "attributes": { "POSITION": healthy_positions }, "material": 0 }] },
            { "name": "Body", "weights": [0.0, 0.0], "primitives": [{
                "attributes": { "POSITION": body_positions, "JOINTS_0": joints, "WEIGHTS_0": weights },
                "targets": [{ "POSITION": morph_0 }, { "POSITION": morph_1 }],
            }] },
        ],
        "skins": [{ "name": "Rig", "joints": [2, 3], "inverseBindMatrices": inverse_binds, "skeleton": 2 }],
        "nodes": [
            { "name": "Healthy", "mesh": 0, "translation": [-2.0, 0.0, 0.0] },
            { "name": "Body", "mesh": 1, "skin": 0 },
            { "name": "Root", "children": [3] },
            { "name": "Arm", "translation": [0.0, 1.0, 0.0] },
            { "name": "Lamp", "translation": [0.0, 3.0, 0.0], "extensions": { "KHR_lights_punctual": { "light": 0 } } },
            { "name": "Eye", "camera": 0, "translation": [0.0, 0.0, 5.0] },
        ],
        "animations": [{
            "name": "Clip",
            "samplers": [
                { "input": t0, "output": healthy_translations, "interpolation": "LINEAR" },
                { "input": t1, "output": arm_rotations, "interpolation": "LINEAR" },
                { "input": t2, "output": morph_weights, "interpolation": "LINEAR" },
                { "input": t3, "output": root_translations, "interpolation": "LINEAR" },
            ],
            "channels": [
                { "sampler": 0, "target": { "node": 0, "path": "translation" } },
                { "sampler": 1, "target": { "node": 3, "path": "rotation" } },
                { "sampler": 2, "target": { "node": 1, "path": "weights" } },
                { "sampler": 3, "target": { "node": 2, "path": "translation" } },
            ],
        }],
        "scenes": [{ "nodes": [0, 1, 2, 4, 5] }],
        "scene": 0,
    }));
    (model, PartsAccessors { joints, weights, inverse_binds, morph_1, arm_times: t1, arm_rotations, root_translations })
}

/// Spawns `scene` into an app, plays its clip `clip` (modulo the count; none without clips) for
/// `frames` frames of 0.3 s and asserts that every global transform, skinning matrix and morph
/// weight is finite after each. Returns the app and the scene's root.
pub fn assert_finite_poses(scene: engine::gltf::GltfScene, clip: usize, frames: usize) -> (engine::app::App, engine::prelude::Entity) {
    use engine::animation::{AnimationPlayer, MorphWeights, SkinPose};
    use engine::prelude::*;
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_millis(300)));
    let root = scene.spawn(&mut app.world);
    let clips = app.world.get::<engine::gltf::GltfAnimations>(root).map(|c| c.0.clone()).unwrap_or_default();
    if !clips.is_empty() {
        app.world.entity_mut(root).insert(AnimationPlayer::new(clips[clip % clips.len()]));
    }
    for frame in 0..frames {
        app.update();
        let world = &mut app.world;
        for global in world.query::<&GlobalTransform>().iter(world) {
            assert!(global.compute_matrix().is_finite(), "frame {frame}: a global transform is not finite: {global:?}");
        }
        for pose in world.query::<&SkinPose>().iter(world) {
            assert!(pose.0.iter().all(|m| m.is_finite()), "frame {frame}: a skinning matrix is not finite");
        }
        for weights in world.query::<&MorphWeights>().iter(world) {
            assert!(weights.0.iter().all(|w| w.is_finite()), "frame {frame}: a morph weight is not finite: {:?}", weights.0);
        }
    }
    (app, root)
}
