//! A broken part costs that part, never the scene (issue 55): for each fault a glTF file may
//! hold, a file written here with a healthy part beside the broken one
//! ([`tests::gltf_files::parts_model`]) loads; the healthy part loads exactly as in the healthy
//! file; one warning names the broken object; `GltfScene::faults` holds it with its kind; the
//! fallback is what `docs/RELIABILITY.md` says; and the scene plays its clip with every pose
//! finite. CPU only: the GPU side of a broken file is in `bad_input`, the environment and light
//! side in `hostile`.

use engine::animation::Property;
use engine::environment::HdrImage;
use engine::gltf::{GltfFaultKind, GltfScene};
use tests::WarningLog;
use tests::gltf_files::{Model, PartsAccessors, assert_finite_poses, parts_model};

/// One fault: how to break the healthy model, what must be said, and what must stand in.
struct Case {
    kind: GltfFaultKind,
    /// Breaks one part of the model.
    breaks: fn(&mut Model, &PartsAccessors),
    /// The object as the warning and the fault name it.
    object: &'static str,
    /// Checks the fallback in the loaded scene.
    fallback: fn(&GltfScene),
}

/// The clip's channel animating `property` of `node`, with its keyframe count.
fn keyframes(scene: &GltfScene, node: usize, property: Property) -> Option<usize> {
    scene.animations[0].channel(node, property).map(|c| c.times().len())
}

fn unskinned(scene: &GltfScene) {
    assert_eq!(scene.nodes[1].skin, None, "the body is drawn unskinned, in its rest pose");
}

fn arm_dropped(scene: &GltfScene) {
    assert_eq!(keyframes(scene, 3, Property::Rotation), None, "the arm's channel is dropped");
    assert_eq!(keyframes(scene, 2, Property::Translation), Some(2), "the root's channel plays");
    assert_eq!(keyframes(scene, 1, Property::Weights), Some(2), "the weights channel plays");
}

fn arm_keeps_one(scene: &GltfScene) {
    assert_eq!(keyframes(scene, 3, Property::Rotation), Some(1), "the arm keeps its other keyframe");
}

const CLIP_CHANNEL_1: &str = "channel 1 (sampler 1) of animation 'Clip' (#0)";

fn cases() -> Vec<Case> {
    vec![
        Case {
            kind: GltfFaultKind::CubicSplineWithoutTangents,
            breaks: |m, _| m.json["animations"][0]["samplers"][1]["interpolation"] = "CUBICSPLINE".into(),
            object: CLIP_CHANNEL_1,
            fallback: arm_dropped,
        },
        Case {
            kind: GltfFaultKind::JointIndexOutOfRange,
            breaks: |m, a| m.write_u16s(a.joints, 2, &[5, 0, 0, 0]),
            object: "skin 'Rig' (#0)",
            fallback: unskinned,
        },
        Case {
            kind: GltfFaultKind::InverseBindMatrixCount,
            breaks: |m, a| m.json["accessors"][a.inverse_binds]["count"] = 1.into(),
            object: "skin 'Rig' (#0)",
            fallback: |scene| {
                unskinned(scene);
                assert!(scene.skins[0].joints.is_empty(), "the refused skin is an empty placeholder");
            },
        },
        Case {
            kind: GltfFaultKind::SamplerCountMismatch,
            breaks: |m, a| m.json["accessors"][a.arm_rotations]["count"] = 1.into(),
            object: CLIP_CHANNEL_1,
            fallback: arm_dropped,
        },
        Case {
            kind: GltfFaultKind::KeyframeTimesNotIncreasing,
            breaks: |m, a| m.write_floats(a.arm_times, 0, &[1.0, 0.5]),
            object: CLIP_CHANNEL_1,
            fallback: arm_dropped,
        },
        Case {
            kind: GltfFaultKind::NonFiniteKeyframes,
            breaks: |m, a| m.write_floats(a.arm_rotations, 1, &[f32::NAN, 0.0, 0.0, 1.0]),
            object: CLIP_CHANNEL_1,
            fallback: arm_keeps_one,
        },
        Case {
            kind: GltfFaultKind::NonFiniteKeyframes,
            breaks: |m, a| m.write_floats(a.root_translations, 1, &[f32::INFINITY, 0.0, 0.0]),
            object: "channel 3 (sampler 3) of animation 'Clip' (#0)",
            fallback: |scene| assert_eq!(keyframes(scene, 2, Property::Translation), Some(1), "the root keeps its finite keyframe"),
        },
        Case {
            kind: GltfFaultKind::ZeroRotationKeyframes,
            breaks: |m, a| m.write_floats(a.arm_rotations, 0, &[0.0; 4]),
            object: CLIP_CHANNEL_1,
            fallback: arm_keeps_one,
        },
        Case {
            kind: GltfFaultKind::MorphTargetLength,
            breaks: |m, a| m.json["accessors"][a.morph_1]["count"] = 2.into(),
            object: "morph target 1 of primitive 0 of mesh 'Body' (#1)",
            fallback: |scene| {
                let targets = &scene.meshes[1][0].0.morph_targets;
                assert_eq!(targets.len(), 2, "the broken target keeps its place");
                assert_eq!(targets[0].positions, vec![[0.0, 0.0, 0.5]; 3], "target 0 applies");
                assert_eq!(targets[1].positions, vec![[0.0; 3]; 3], "target 1 has no effect");
            },
        },
        Case {
            kind: GltfFaultKind::DegenerateWeights,
            breaks: |m, a| m.write_floats(a.weights, 2, &[f32::NAN, 0.0, 0.0, 0.0]),
            object: "joints and weights of primitive 0 of mesh 'Body' (#1)",
            fallback: |scene| {
                let skin = scene.meshes[1][0].0.skin.as_ref().unwrap();
                assert_eq!(
                    skin.weights,
                    vec![[1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]],
                    "vertex 2 follows its first joint"
                );
                assert_eq!(scene.nodes[1].skin, Some(0), "the rest of the skin deforms");
            },
        },
        Case {
            kind: GltfFaultKind::DegenerateWeights,
            breaks: |m, a| m.write_floats(a.weights, 1, &[0.0; 4]),
            object: "joints and weights of primitive 0 of mesh 'Body' (#1)",
            fallback: |scene| {
                let skin = scene.meshes[1][0].0.skin.as_ref().unwrap();
                assert_eq!(skin.weights[1], [1.0, 0.0, 0.0, 0.0], "vertex 1 follows its first joint");
                assert_eq!(skin.joints[1][0], 1);
            },
        },
        Case {
            kind: GltfFaultKind::JointIsSkinnedNode,
            breaks: |m, _| m.json["skins"][0]["joints"] = serde_json::json!([2, 1]),
            object: "joint 1 (node #1) of skin 'Rig' (#0)",
            fallback: unskinned,
        },
        Case {
            kind: GltfFaultKind::DegenerateTransform,
            breaks: |m, _| m.json["nodes"][2]["translation"] = serde_json::json!([1e39, 0.0, 0.0]),
            object: "node 'Root' (#2)",
            fallback: |scene| assert_eq!(scene.nodes[2].transform.translation, glam::Vec3::ZERO),
        },
        Case {
            kind: GltfFaultKind::BadLight,
            breaks: |m, _| m.json["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = (-1.0).into(),
            object: "light 'Lamp' (#0)",
            fallback: |scene| assert_eq!(scene.nodes[4].light, None, "the lamp has no light"),
        },
        Case {
            kind: GltfFaultKind::BadLight,
            breaks: |m, _| m.json["extensions"]["KHR_lights_punctual"]["lights"][0]["extras"] = serde_json::json!({ "radius": -0.5 }),
            object: "light 'Lamp' (#0)",
            fallback: |scene| assert_eq!(scene.nodes[4].light, None, "the lamp has no light"),
        },
        Case {
            kind: GltfFaultKind::BadCamera,
            breaks: |m, _| m.json["cameras"][0]["perspective"]["yfov"] = 1e39.into(),
            object: "camera 'Eye' (#0)",
            fallback: |scene| {
                let camera = scene.nodes[5].camera.expect("the eye keeps a camera");
                assert_eq!(
                    (camera.fov_y, camera.near),
                    (engine::camera::Camera::default().fov_y, 0.1),
                    "the default view, its own near plane"
                );
            },
        },
        Case {
            kind: GltfFaultKind::BadMaterial,
            breaks: |m, _| m.json["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = 1e39.into(),
            object: "material 'Paint' (#0)",
            fallback: |scene| {
                assert_eq!(scene.materials[0].metallic, 1.0, "glTF's default metallic factor");
                assert_eq!(scene.materials[0].roughness, 0.6, "the finite factors stay");
            },
        },
        // Parts that cannot be read at all.
        Case {
            kind: GltfFaultKind::BadSkin,
            breaks: |m, a| m.json["accessors"][a.inverse_binds]["componentType"] = 5123.into(),
            object: "skin 'Rig' (#0)",
            fallback: unskinned,
        },
        Case {
            kind: GltfFaultKind::BadChannel,
            breaks: |m, a| m.json["accessors"][a.arm_rotations]["type"] = "VEC3".into(),
            object: CLIP_CHANNEL_1,
            fallback: arm_dropped,
        },
        Case {
            kind: GltfFaultKind::BadSkinWeights,
            breaks: |m, a| m.json["accessors"][a.weights]["count"] = 2.into(),
            object: "joints and weights of primitive 0 of mesh 'Body' (#1)",
            fallback: |scene| assert_eq!(scene.meshes[1][0].0.skin, None, "the body is drawn rigidly"),
        },
        Case {
            kind: GltfFaultKind::BadMorphTarget,
            breaks: |m, a| m.write_floats(a.morph_1, 1, &[f32::NAN, 0.0, 0.0]),
            object: "morph target 1 of primitive 0 of mesh 'Body' (#1)",
            fallback: |scene| assert_eq!(scene.meshes[1][0].0.morph_targets[1].positions, vec![[0.0; 3]; 3], "target 1 has no effect"),
        },
    ]
}

#[test]
fn the_parts_model_loads_healthy_without_a_word_and_poses_finitely() {
    let (model, _) = parts_model();
    let log = WarningLog::capture_thread();
    let scene = model.load().expect("the healthy model loads");
    assert!(log.warnings().is_empty(), "{:?}", log.warnings());
    assert!(scene.faults.is_empty(), "{:?}", scene.faults);
    assert_eq!((scene.nodes[1].skin, scene.skins[0].joints.clone()), (Some(0), vec![2, 3]));
    assert_eq!(scene.animations[0].channels().len(), 4);
    assert_eq!(scene.meshes[1][0].0.morph_targets.len(), 2);
    assert!(scene.nodes[4].light.is_some() && scene.nodes[5].camera.is_some());
    assert_finite_poses(scene, 0, 4);
    // A light's size comes from its extras (radius 0 without).
    let radius = |scene: &GltfScene| match scene.nodes[4].light {
        Some(engine::gltf::GltfLight::Point(p)) => p.radius,
        ref other => panic!("the lamp is a point light: {other:?}"),
    };
    assert_eq!(radius(&model.load().unwrap()), 0.0);
    let mut sized = model.clone();
    sized.json["extensions"]["KHR_lights_punctual"]["lights"][0]["extras"] = serde_json::json!({ "radius": 0.25 });
    assert_eq!(radius(&sized.load().unwrap()), 0.25);
}

#[test]
fn each_broken_part_costs_only_itself_with_one_warning_and_one_fault() {
    let (model, accessors) = parts_model();
    let healthy = model.load().unwrap();
    let mut kinds = Vec::new();
    for case in cases() {
        let mut broken = model.clone();
        (case.breaks)(&mut broken, &accessors);
        let log = WarningLog::capture_thread();
        let scene = broken.load().unwrap_or_else(|e| panic!("{:?}: the file loads: {e}", case.kind));
        let warnings = log.warnings();
        assert_eq!(warnings.len(), 1, "{:?}: one warning: {warnings:?}", case.kind);
        assert!(
            warnings[0].message.contains(case.object) && warnings[0].message.contains("<memory>"),
            "{:?}: the warning names the file and {}: {}",
            case.kind,
            case.object,
            warnings[0].message
        );
        assert_eq!(scene.faults.len(), 1, "{:?}: {:?}", case.kind, scene.faults);
        let fault = &scene.faults[0];
        assert_eq!(fault.kind, case.kind, "{fault}");
        assert_eq!(fault.part.to_string(), case.object, "{fault}");
        assert!(!fault.fallback.is_empty());
        // The healthy part loads as it does in the healthy file.
        assert_eq!(scene.meshes[0], healthy.meshes[0], "{:?}: the healthy mesh", case.kind);
        assert_eq!(scene.nodes[0], healthy.nodes[0], "{:?}: the healthy node", case.kind);
        assert_eq!(
            scene.animations[0].channel(0, Property::Translation),
            healthy.animations[0].channel(0, Property::Translation),
            "{:?}: the healthy channel",
            case.kind
        );
        (case.fallback)(&scene);
        assert_finite_poses(scene, 0, 4);
        kinds.push(case.kind);
    }
    kinds.sort_by_key(|k| format!("{k:?}"));
    kinds.dedup();
    assert_eq!(kinds.len(), 18, "every kind of fault is exercised: {kinds:?}");
}

#[test]
fn environment_texels_beyond_half_floats_are_clamped_on_load_with_one_warning() {
    let dir = std::env::temp_dir().join(format!("ecs-decals-reliability-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A legal Radiance file, absurdly bright where it is not ordinary.
    let (width, height) = (8u32, 4u32);
    let texels: Vec<image::Rgb<f32>> =
        (0..width * height).map(|i| image::Rgb(if i % 3 == 0 { [1e30, 3e30, 2e30] } else { [0.5, 0.25, 1.0] })).collect();
    let path = dir.join("blinding.hdr");
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    image::codecs::hdr::HdrEncoder::new(file).encode(&texels, width as usize, height as usize).unwrap();
    let log = WarningLog::capture_thread();
    let map = HdrImage::load(&path).expect("the map loads");
    let warnings = log.warnings();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].message.contains("blinding.hdr") && warnings[0].message.contains("65504"), "{}", warnings[0].message);
    assert!(map.texels.iter().flatten().all(|c| c.is_finite() && *c <= 65504.0));
    assert_eq!(map.texels[0], [65504.0; 3]);
    assert_eq!(map.texels[1], [0.5, 0.25, 1.0], "ordinary texels are untouched");
    // The same in a KTX2 cube map of 32-bit floats, infinities included.
    let mut data = Vec::new();
    for i in 0..6 * 4 {
        let texel = if i == 5 { [f32::INFINITY, 1e20, 2.0, 1.0] } else { [1.0, 1.0, 1.0, 1.0] };
        data.extend(texel.iter().flat_map(|c| c.to_le_bytes()));
    }
    let bytes = tests::ktx2_file(ktx2::Format::R32G32B32A32_SFLOAT, 2, 2, 6, &data);
    let map = HdrImage::from_ktx2(&bytes, "cube.ktx2").unwrap();
    assert_eq!(map.texels[5], [0.0, 65504.0, 2.0], "infinity is no radiance (as NaN), 1e20 the brightest half float");
    let warnings = log.warnings();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[1].message.contains("cube.ktx2"), "{}", warnings[1].message);
    std::fs::remove_dir_all(&dir).ok();
}
