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

/// The animation budget: a fox near the camera samples its clip every frame, one 200 m away
/// (a few pixels) every fourth frame, staggered, and a sampled pose is the pose of the current
/// time, exactly what the same fox shows with the budget off. Between its samples nothing of
/// the far fox is written, so nothing downstream (propagation, skin matrices) runs for it.
#[test]
fn the_animation_budget_samples_a_far_fox_every_fourth_frame_at_the_current_time() {
    // With bones as entities, then as compact skeletons against the same reference.
    for compact in [false, true] {
        budget_samples_a_far_fox(compact);
    }
}

fn budget_samples_a_far_fox(compact: bool) {
    use engine::animation::{AnimatedRadius, AnimationBudget, AnimationOutput, AnimationStats, SkinPose};
    use engine::camera::Camera;

    let mut scene = gltf::load(&model("Fox")).unwrap();
    scene.images.clear();
    // Two worlds, the budget on in the first only; in each a near and a far fox, and a camera at
    // the origin looking down -Z.
    let world = |budget: bool, compact: bool| {
        let mut app = App::new();
        app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_micros(16_667)));
        *app.world.resource_mut::<AnimationBudget>() =
            AnimationBudget { enabled: budget, viewport: Vec2::new(1920.0, 1080.0), ..Default::default() };
        app.world.spawn((Camera::default(), Transform::IDENTITY));
        let mut prefab = scene.clone().into_prefab(&mut app.world);
        prefab.compact_skeletons = compact;
        let foxes: Vec<(Entity, Entity)> = [-3.0, -200.0]
            .into_iter()
            .map(|z| {
                let root = prefab.spawn(&mut app.world);
                let run = app.world.get::<GltfAnimations>(root).unwrap().0[2];
                // The file is in centimetres.
                let at = Transform::from_xyz(0.0, 0.0, z).with_scale(Vec3::splat(0.01));
                app.world.entity_mut(root).insert((AnimationPlayer::new(run), at));
                app.world.flush();
                // Its skinned mesh: the one whose joints it animates.
                let targets = app.world.get::<engine::animation::AnimationTargets>(root).unwrap().0.clone();
                let mesh =
                    app.world.query::<(Entity, &Skin)>().iter(&app.world).find(|(_, s)| targets.contains(&Some(s.joints[0]))).unwrap().0;
                (root, mesh)
            })
            .collect();
        (app, foxes)
    };
    let (mut budgeted, foxes) = world(true, compact);
    let (mut reference, same) = world(false, false);
    let radius = budgeted.world.get::<AnimatedRadius>(foxes[0].0).expect("the glTF spawner sets the radius").0;
    assert!((50.0..300.0).contains(&radius), "the fox's rest radius is about its length: {radius} cm");

    // The first update places the foxes (a player not yet placed samples every frame).
    budgeted.update();
    reference.update();
    let pose = |app: &App, mesh: Entity| app.world.get::<SkinPose>(mesh).unwrap().0.clone();
    let mut last = [pose(&budgeted, foxes[0].1), pose(&budgeted, foxes[1].1)];
    let mut far_samples = 0;
    for frame in 0..16 {
        budgeted.update();
        reference.update();
        let out = |i: usize| *budgeted.world.get::<AnimationOutput>(foxes[i].0).unwrap();
        let (near, far) = (out(0), out(1));
        assert_eq!((near.period(), near.sampled()), (1, true), "frame {frame}: the near fox samples every frame");
        assert_eq!(far.period(), 4, "frame {frame}: the far fox, a few pixels, every fourth frame");
        far_samples += u32::from(far.sampled());
        let stats = *budgeted.world.resource::<AnimationStats>();
        assert_eq!((stats.players, stats.sampled, stats.max_period), (2, 1 + u32::from(far.sampled()), 4), "frame {frame}");
        for (i, &(_, mesh)) in foxes.iter().enumerate() {
            let now = pose(&budgeted, mesh);
            let sampled = i == 0 || far.sampled();
            assert_eq!(now != last[i], sampled, "frame {frame}, fox {i}: the pose changes exactly when it is sampled");
            if sampled {
                let expected = pose(&reference, same[i].1);
                // The same arithmetic with bones as entities. A compact skin multiplies from
                // the model's root, not the world's: the reference's bones, 200 m away, round
                // in world space, and the two differ by that rounding (5e-4 of a matrix entry
                // here; a wrong pose differs by tenths).
                let worst = now
                    .iter()
                    .zip(&expected)
                    .flat_map(|(a, b)| a.to_cols_array().into_iter().zip(b.to_cols_array()))
                    .map(|(x, y)| (x - y).abs() / x.abs().max(1.0))
                    .fold(0.0f32, f32::max);
                let tolerance = if compact { 2e-3 } else { 1e-5 };
                assert!(worst <= tolerance, "frame {frame}, fox {i}: a sampled pose is the pose of the current time ({worst})");
            }
            last[i] = now;
        }
    }
    assert_eq!(far_samples, 4, "16 frames: the far fox sampled four times (compact: {compact})");

    // The far fox walks 1 m a frame: on a frame it does not sample, its bones' entities still
    // follow it (a compact skin places them from its standing pose).
    let far_joints = budgeted.world.get::<Skin>(foxes[1].1).unwrap().joints.clone();
    let mut skipped = 0;
    for _ in 0..4 {
        let before: Vec<Vec3> =
            far_joints.iter().map(|&j| budgeted.world.get::<GlobalTransform>(j).unwrap().0.translation.into()).collect();
        budgeted.world.get_mut::<Transform>(foxes[1].0).unwrap().translation.x += 1.0;
        budgeted.update();
        if budgeted.world.get::<AnimationOutput>(foxes[1].0).unwrap().sampled() {
            continue;
        }
        skipped += 1;
        for (&joint, before) in far_joints.iter().zip(before) {
            let now: Vec3 = budgeted.world.get::<GlobalTransform>(joint).unwrap().0.translation.into();
            assert!(now.abs_diff_eq(before + Vec3::X, 1e-3), "compact {compact}: a bone of the walking far fox at {now}, from {before}");
        }
    }
    assert_eq!(skipped, 3, "four frames: three without sampling");
}

/// A compact skeleton (`engine::animation::CompactSkeleton`, as the prefab spawns skins) poses
/// the fox as its bones' entities would, through a cross-fade and while the fox moves, and
/// places those entities where they would be; with `UnplacedBones` it leaves them alone, and
/// `SkinPose::joint_world` gives a bone's world transform back. Removing the mark gives the
/// bones back to animation, a skin with something hung on a bone refuses it, and a bone's
/// `Transform` written by the game (inverse kinematics) poses the skin as it poses bones as
/// entities, which the skin then goes back to.
#[test]
fn a_compact_skeleton_poses_the_fox_as_its_bones_would_and_places_them() {
    use engine::animation::{AnimationSystems, AnimationTargets, CompactSkeleton, PosedInSkin, SkinPose, SkinRig, UnplacedBones};
    use engine::app::PostUpdate;
    use engine::transform::TransformSystems;

    let mut scene = gltf::load(&model("Fox")).unwrap();
    scene.images.clear();
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_micros(16_667)));
    let mut prefab = scene.into_prefab(&mut app.world);
    // Five foxes in the same place: bones as entities, compact with its bones unplaced, compact
    // (as the prefab spawns it) until a sword is hung in a bone's hand, compact with its player
    // given late, and compact placing its bones.
    let foxes: Vec<(Entity, Entity)> = (0..5)
        .map(|i| {
            (prefab.compact_skeletons, prefab.unplaced_bones) = (i > 0, i == 1);
            let root = prefab.spawn(&mut app.world);
            let clips = app.world.get::<GltfAnimations>(root).unwrap().0.clone();
            let mut player = AnimationPlayer::new(clips[1]);
            player.seek(0.4);
            app.world.entity_mut(root).insert(Transform::from_xyz(1.0, 0.0, 0.0).with_scale(Vec3::splat(0.01)));
            if i != 3 {
                app.world.entity_mut(root).insert(player);
            }
            app.world.flush();
            let targets = app.world.get::<AnimationTargets>(root).unwrap().0.clone();
            let mesh = app.world.query::<(Entity, &Skin)>().iter(&app.world).find(|(_, s)| targets.contains(&Some(s.joints[0]))).unwrap().0;
            (root, mesh)
        })
        .collect();
    let [(entities, bones_mesh), (compact, compact_mesh), (armed, armed_mesh), (late, late_mesh), (placed, placed_mesh)] = foxes[..] else {
        unreachable!()
    };
    assert!(app.world.get::<UnplacedBones>(compact_mesh).is_some() && app.world.get::<UnplacedBones>(placed_mesh).is_none());
    let hand = app.world.get::<Skin>(armed_mesh).unwrap().joints[10];
    let joints = app.world.get::<Skin>(compact_mesh).unwrap().joints.clone();
    let rest: Vec<Transform> = joints.iter().map(|&j| *app.world.get::<Transform>(j).unwrap()).collect();

    let clips = app.world.get::<GltfAnimations>(entities).unwrap().0.clone();
    let pose = |app: &App, mesh: Entity| app.world.get::<SkinPose>(mesh).unwrap().0.clone();
    let same = |a: &[Mat4], b: &[Mat4]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(a, b)| a.to_cols_array().iter().zip(b.to_cols_array()).all(|(x, y)| (x - y).abs() <= 1e-4 * x.abs().max(1.0)))
    };
    let mut rest_globals: Option<Vec<GlobalTransform>> = None;
    for frame in 0..12 {
        if frame == 4 {
            // Walk to run, over a fifth of a second.
            for root in [entities, compact, armed, placed] {
                app.world.get_mut::<AnimationPlayer>(root).unwrap().cross_fade(clips[2], 0.2);
            }
        }
        if frame == 2 {
            assert!(app.world.get::<CompactSkeleton>(armed_mesh).is_some());
            app.world.spawn((Transform::IDENTITY, ChildOf(hand)));
        }
        if frame == 6 {
            // The late fox gets its player, in the state the others' players are in.
            let player = app.world.get::<AnimationPlayer>(entities).unwrap().clone();
            app.world.entity_mut(late).insert(player);
        }
        for root in [entities, compact, armed, late, placed] {
            app.world.get_mut::<Transform>(root).unwrap().translation.z = frame as f32 * 0.1;
        }
        app.update();
        let reference = pose(&app, bones_mesh);
        assert!(same(&pose(&app, compact_mesh), &reference), "frame {frame}: the compact skin's pose is the bones' pose");
        assert!(same(&pose(&app, placed_mesh), &reference), "frame {frame}: placing the bones too");
        // The placed fox's bones are where the reference fox's are, local and world.
        let reference_joints = app.world.get::<Skin>(bones_mesh).unwrap().joints.clone();
        let placed_joints = app.world.get::<Skin>(placed_mesh).unwrap().joints.clone();
        for (i, (&r, &p)) in reference_joints.iter().zip(&placed_joints).enumerate() {
            let (rt, pt) = (app.world.get::<Transform>(r).unwrap(), app.world.get::<Transform>(p).unwrap());
            assert!(
                rt.translation.abs_diff_eq(pt.translation, 1e-4)
                    && rt.rotation.abs_diff_eq(pt.rotation, 1e-5)
                    && rt.scale.abs_diff_eq(pt.scale, 1e-5),
                "frame {frame}, bone {i}: {pt:?} against {rt:?}"
            );
            let (rg, pg) = (app.world.get::<GlobalTransform>(r).unwrap().0, app.world.get::<GlobalTransform>(p).unwrap().0);
            assert!(pg.abs_diff_eq(rg, 1e-4), "frame {frame}, bone {i}: placed at {pg:?}, its bone entity's twin at {rg:?}");
        }
        assert!(same(&pose(&app, armed_mesh), &reference), "frame {frame}: the armed fox, compact or with its bones as entities, too");
        assert_eq!(same(&pose(&app, late_mesh), &reference), frame >= 6, "frame {frame}: the late fox is posed once it has a player");
        if frame >= 2 {
            assert!(app.world.get::<CompactSkeleton>(armed_mesh).is_none(), "a bone carrying a sword needs its skin's bones as entities");
        }
        let moved_bones = joints.iter().zip(&rest).filter(|&(&j, r)| app.world.get::<Transform>(j).unwrap() != r).count();
        assert_eq!(moved_bones, 0, "frame {frame}: the unplaced skin's bones keep their rest transforms");
        let globals: Vec<GlobalTransform> = joints.iter().map(|&j| *app.world.get::<GlobalTransform>(j).unwrap()).collect();
        let first = rest_globals.get_or_insert_with(|| globals.clone());
        assert_eq!(&globals, first, "frame {frame}: nothing places the unplaced skin's bones while the fox moves");
        assert!(joints.iter().all(|&j| app.world.get::<PosedInSkin>(j).is_some()));
        let skin = app.world.get::<Skin>(compact_mesh).unwrap();
        let mesh_world = app.world.get::<GlobalTransform>(compact_mesh).unwrap();
        let reference_joints = &app.world.get::<Skin>(bones_mesh).unwrap().joints;
        for (i, &joint) in reference_joints.iter().enumerate() {
            let world = pose(&app, compact_mesh);
            let found = SkinPose(world).joint_world(skin, mesh_world, i).expect("an invertible bind matrix");
            let expected = app.world.get::<GlobalTransform>(joint).unwrap().0;
            assert!(found.abs_diff_eq(expected, 1e-4), "frame {frame}, joint {i}: {found:?} against {expected:?}");
        }
    }

    // Paused, a compact skin's pose is not written again: nothing downstream runs for it.
    #[derive(Resource, Default)]
    struct Posed(Vec<Entity>);
    app.world.init_resource::<Posed>();
    app.add_systems(engine::app::Render, |changed: Query<Entity, Changed<SkinPose>>, mut posed: ResMut<Posed>| {
        posed.0 = changed.iter().collect();
    });
    app.update();
    app.update();
    assert!(app.world.resource::<Posed>().0.contains(&compact_mesh), "it changes while walking");
    for root in [entities, compact, armed, late, placed] {
        app.world.get_mut::<AnimationPlayer>(root).unwrap().paused = true;
    }
    app.update();
    app.update();
    assert!(app.world.resource::<Posed>().0.is_empty(), "paused, no pose changes: {:?}", app.world.resource::<Posed>().0);
    for root in [entities, compact, armed, late, placed] {
        app.world.get_mut::<AnimationPlayer>(root).unwrap().paused = false;
    }

    // Without the mark, animation moves the bones again and the pose stays the same.
    app.world.entity_mut(compact_mesh).remove::<CompactSkeleton>();
    for _ in 0..2 {
        app.update();
    }
    assert!(same(&pose(&app, compact_mesh), &pose(&app, bones_mesh)));
    let moved_bones = joints.iter().zip(&rest).filter(|&(&j, r)| app.world.get::<Transform>(j).unwrap() != r).count();
    assert!(moved_bones > 12, "the bones move again: {moved_bones} of 24");
    assert!(joints.iter().all(|&j| app.world.get::<PosedInSkin>(j).is_none()));

    // A skin posed from its joints' entities, given the late fox's bones, takes them back.
    let late_skin = app.world.get::<Skin>(late_mesh).unwrap().clone();
    let late_joints = late_skin.joints.clone();
    assert!(late_joints.iter().all(|&j| app.world.get::<PosedInSkin>(j).is_some()));
    let second = app.world.spawn((late_skin, Transform::IDENTITY, ChildOf(app.world.get::<ChildOf>(late_mesh).unwrap().parent()))).id();
    for _ in 0..2 {
        app.update();
    }
    assert!(app.world.get::<CompactSkeleton>(late_mesh).is_none(), "the compact skeleton gave its bones back");
    assert!(late_joints.iter().all(|&j| app.world.get::<PosedInSkin>(j).is_none()));
    assert!(same(&pose(&app, second), &pose(&app, bones_mesh)), "the second skin follows the bones");
    assert!(same(&pose(&app, late_mesh), &pose(&app, bones_mesh)));

    // A second compact skin on the placed fox's skeleton (as a glTF mesh's other primitives
    // have): one of the two owns and places the bones, the other follows them.
    let placed_skin = app.world.get::<Skin>(placed_mesh).unwrap().clone();
    let twin = app
        .world
        .spawn((placed_skin, CompactSkeleton, Transform::IDENTITY, ChildOf(app.world.get::<ChildOf>(placed_mesh).unwrap().parent())))
        .id();
    for _ in 0..2 {
        app.update();
    }
    let rigs = [placed_mesh, twin].map(|mesh| app.world.get::<SkinRig>(mesh).expect("both compact").follows());
    assert_eq!(rigs.iter().filter(|&&f| f).count(), 1, "one of the two follows the other's bones: {rigs:?}");
    assert!(same(&pose(&app, twin), &pose(&app, bones_mesh)) && same(&pose(&app, placed_mesh), &pose(&app, bones_mesh)));

    // Inverse kinematics: a system between animation and propagation sets bone 5's whole
    // `Transform` on the reference fox and the placed one. The placed skins are posed from the
    // written transform that frame, as the bones' entities are, and the owner then gives its
    // bones back (the follower follows them still).
    #[derive(Resource)]
    struct Ik(Vec<Entity>);
    let ik_bones = vec![app.world.get::<Skin>(bones_mesh).unwrap().joints[5], app.world.get::<Skin>(placed_mesh).unwrap().joints[5]];
    app.world.insert_resource(Ik(ik_bones));
    app.add_systems(
        PostUpdate,
        (|ik: Res<Ik>, mut transforms: Query<&mut Transform>| {
            for &bone in &ik.0 {
                *transforms.get_mut(bone).unwrap() = Transform::from_xyz(0.0, 5.0, 0.0).with_rotation(Quat::from_rotation_x(0.7));
            }
        })
        .after(AnimationSystems)
        .before(TransformSystems::Propagate),
    );
    for frame in 0..3 {
        app.update();
        assert!(same(&pose(&app, placed_mesh), &pose(&app, bones_mesh)), "IK frame {frame}: the written bone poses the skin");
        assert!(same(&pose(&app, twin), &pose(&app, bones_mesh)), "IK frame {frame}: and the skin that shares its skeleton");
        let bones_far = pose(&app, placed_mesh).iter().zip(pose(&app, compact_mesh)).any(|(a, b)| !a.abs_diff_eq(b, 1e-3));
        assert!(bones_far, "IK frame {frame}: the written bone moved the skin away from the unwritten fox's pose");
        let owner = [placed_mesh, twin].into_iter().find(|&m| app.world.get::<CompactSkeleton>(m).is_none());
        assert!(owner.is_some(), "IK frame {frame}: the owner went back to bones as entities");
    }
}
