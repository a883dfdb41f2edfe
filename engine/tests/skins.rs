//! Skins, morph targets and animations from the shared sample models (`../shared/assets/gltf`:
//! the tests fail when they are missing), and faults naming malformed skins, which cost their mesh
//! its pose and nothing else.

#![forbid(unsafe_code)]

use std::path::PathBuf;
use std::time::Duration;

use ::gltf::json::Value;
use engine::animation::{AnimationPlayer, MorphWeights, Skin};
use engine::gltf::{self, GltfAnimations, GltfFaultKind};
use engine::prelude::*;

fn model(name: &str) -> PathBuf {
    let path = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/assets/gltf")).join(name).join(format!("{name}.glb"));
    assert!(path.exists(), "the shared model {} is missing: it lives beside the project", path.display());
    path
}

/// The JSON and binary chunks of a GLB file.
fn glb_chunks(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json = ::gltf::json::deserialize::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin = bytes[bin_at + 8..bin_at + 8 + u32_at(bin_at)].to_vec();
    (json, bin)
}

#[test]
fn the_fox_loads_its_skin_and_clips_and_walks() {
    let scene = gltf::load(&model("Fox")).unwrap();
    assert_eq!(scene.skins.len(), 1);
    assert_eq!(scene.skins[0].joints.len(), 24);
    let names: Vec<&str> = scene.animations.iter().map(|a| a.name()).collect();
    assert_eq!(names, ["Survey", "Walk", "Run"]);
    let (mesh, _) = &scene.meshes[0][0];
    let skin = mesh.skin.as_ref().expect("the fox's mesh is skinned");
    assert!(skin.weights.iter().all(|w| (w.iter().sum::<f32>() - 1.0).abs() < 1e-5));

    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_millis(50)));
    let root = scene.spawn(&mut app.world);
    let clips = app.world.get::<GltfAnimations>(root).expect("clips on the root").0.clone();
    let skinned: Vec<Skin> = app.world.query::<&Skin>().iter(&app.world).cloned().collect();
    assert_eq!(skinned.len(), 1);
    let joints = skinned[0].joints.clone();
    assert_eq!(joints.len(), 24);
    app.update();
    let rest: Vec<Mat4> = joints.iter().map(|&j| app.world.get::<GlobalTransform>(j).unwrap().compute_matrix()).collect();
    app.world.entity_mut(root).insert(AnimationPlayer::new(clips[1]));
    for _ in 0..5 {
        app.update();
    }
    let moved = joints
        .iter()
        .zip(&rest)
        .filter(|(j, r)| !app.world.get::<GlobalTransform>(**j).unwrap().compute_matrix().abs_diff_eq(**r, 1e-4))
        .count();
    assert!(moved > 12, "walking moves most of the fox's joints: {moved} of 24 moved");
}

#[test]
fn cesium_man_weights_are_normalised_and_the_robot_brings_two_skins_morph_targets_and_fourteen_clips() {
    let man = gltf::load(&model("CesiumMan")).unwrap();
    let weights = &man.meshes.iter().flatten().find_map(|(m, _)| m.skin.as_ref()).expect("skinned").weights;
    assert!(weights.iter().all(|w| (w.iter().sum::<f32>() - 1.0).abs() < 1e-5), "weights sum to 1 after loading");
    assert_eq!(man.animations.len(), 1);

    let robot = gltf::load(&model("RobotExpressive")).unwrap();
    assert_eq!(robot.animations.len(), 14);
    assert_eq!(robot.skins.len(), 2, "skins: {:?}", robot.skins.iter().map(|s| &s.name).collect::<Vec<_>>());
    let targets: usize = robot.meshes.iter().flatten().map(|(m, _)| m.morph_targets.len()).max().unwrap_or(0);
    assert!(targets > 0, "the robot's face has morph targets");
    let mut app = App::new();
    let root = robot.spawn(&mut app.world);
    app.update();
    assert!(app.world.query::<&MorphWeights>().iter(&app.world).any(|w| !w.0.is_empty()));
    assert!(app.world.get::<GltfAnimations>(root).is_some());
}

#[test]
fn malformed_skins_cost_their_mesh_its_pose_naming_the_skin_and_the_problem() {
    let bytes = std::fs::read(model("Fox")).unwrap();
    let (json, bin) = glb_chunks(&bytes);
    let load = |json: &Value| gltf::load_slice(&gltf::glb_container(&::gltf::json::serialize::to_vec(json).unwrap(), &bin), None);
    let healthy = load(&json).unwrap();
    assert!(healthy.faults.is_empty(), "the fox is healthy: {:?}", healthy.faults);
    let skinned = |scene: &gltf::GltfScene| scene.nodes.iter().filter(|n| n.skin.is_some()).count();
    assert_eq!(skinned(&healthy), 1);

    // Each broken skin loads: the mesh stays (unskinned), the clips stay, one fault names the skin.
    let ibm = json["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize;
    let mut few = json.clone();
    let joints = few["skins"][0]["joints"].as_array().unwrap()[..5].to_vec();
    few["skins"][0]["joints"] = joints.into();
    few["accessors"][ibm]["count"] = 5.into();
    let mut mismatched = json.clone();
    mismatched["accessors"][ibm]["count"] = 3.into();
    let mut ints = json.clone();
    ints["accessors"][ibm]["componentType"] = 5123.into();
    for (broken, kind, says) in [
        (few, GltfFaultKind::JointIndexOutOfRange, "but the skin has 5 joints"),
        (mismatched, GltfFaultKind::InverseBindMatrixCount, "3 inverse bind matrices for 24 joints"),
        (ints, GltfFaultKind::BadSkin, "not float MAT4"),
    ] {
        let scene = load(&broken).unwrap();
        assert_eq!(scene.faults.len(), 1, "{:?}", scene.faults);
        let fault = &scene.faults[0];
        assert_eq!(fault.kind, kind, "{fault}");
        assert!(matches!(fault.part, gltf::GltfPart::Skin { index: 0, .. }), "{fault}");
        assert!(fault.to_string().contains(says) && fault.to_string().contains("<memory>"), "{fault}");
        assert_eq!(skinned(&scene), 0, "the mesh is drawn unskinned");
        assert_eq!((scene.triangle_count(), scene.animations.len()), (healthy.triangle_count(), 3));
    }
}
