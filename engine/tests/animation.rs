//! Headless tests of animation playback through the app's schedules, at a fixed step so that
//! every value can be computed by hand.

#![forbid(unsafe_code)]

use std::time::Duration;

use engine::animation::{
    AnimationClip, AnimationPlayer, AnimationTargets, Channel, Interpolation, Keyframes, MorphWeights, Property, Repeat,
};
use engine::prelude::*;

/// An app stepping 0.25 s a frame, a joint, and clips: `slide` moves x from 0 to 2 over 2 s;
/// `hold` keeps x at 10.
fn app() -> (App, Entity, Handle<AnimationClip>, Handle<AnimationClip>) {
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_millis(250)));
    let joint = app.world.spawn(Transform::IDENTITY).id();
    let x = |v: f32| Vec3::new(v, 0.0, 0.0);
    let slide = AnimationClip::new(
        "slide",
        vec![Channel::new(0, Interpolation::Linear, vec![0.0, 2.0], Keyframes::Translation(vec![x(0.0), x(2.0)]))],
    );
    let hold = AnimationClip::new("hold", vec![Channel::new(0, Interpolation::Step, vec![0.0], Keyframes::Translation(vec![x(10.0)]))]);
    let mut clips = app.world.resource_mut::<Assets<AnimationClip>>();
    let (slide, hold) = (clips.add(slide.unwrap()), clips.add(hold.unwrap()));
    (app, joint, slide, hold)
}

fn x(app: &App, e: Entity) -> f32 {
    app.world.get::<GlobalTransform>(e).unwrap().translation().x
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

#[test]
fn a_player_loops_clamps_pauses_seeks_and_changes_speed() {
    let (mut app, joint, slide, _) = app();
    let player = app.world.spawn((AnimationPlayer::new(slide), AnimationTargets(vec![Some(joint)]))).id();
    app.update();
    assert!(close(x(&app, joint), 0.25), "{}", x(&app, joint));
    for _ in 0..3 {
        app.update();
    }
    assert!(close(x(&app, joint), 1.0));
    // Looping: 2.5 s is 0.5 s into the second round.
    for _ in 0..6 {
        app.update();
    }
    assert!(close(x(&app, joint), 0.5), "{}", x(&app, joint));
    // Paused: nothing moves, and the transform is not even flagged changed.
    app.world.get_mut::<AnimationPlayer>(player).unwrap().paused = true;
    app.update();
    let before = app.world.entity(joint).get_ref::<Transform>().unwrap().last_changed();
    app.update();
    assert!(close(x(&app, joint), 0.5));
    assert_eq!(app.world.entity(joint).get_ref::<Transform>().unwrap().last_changed(), before);
    // Seek, double speed, and clamp at the end.
    {
        let mut p = app.world.get_mut::<AnimationPlayer>(player).unwrap();
        p.paused = false;
        p.seek(1.0);
        p.speed = 2.0;
        p.repeat = Repeat::Clamp;
    }
    app.update();
    assert!(close(x(&app, joint), 1.5), "{}", x(&app, joint));
    for _ in 0..8 {
        app.update();
    }
    assert!(close(x(&app, joint), 2.0), "clamped at the end: {}", x(&app, joint));
}

#[test]
fn a_cross_fade_blends_from_the_old_clip_to_the_new_one() {
    let (mut app, joint, slide, hold) = app();
    let player = app.world.spawn((AnimationPlayer::new(slide), AnimationTargets(vec![Some(joint)]))).id();
    for _ in 0..4 {
        app.update();
    }
    assert!(close(x(&app, joint), 1.0));
    app.world.get_mut::<AnimationPlayer>(player).unwrap().cross_fade(hold, 1.0);
    // 0.5 s into a 1 s fade: half of slide (now at 1.5 s: 1.5) and half of hold (10).
    app.update();
    app.update();
    assert!(close(x(&app, joint), 0.5 * 1.5 + 0.5 * 10.0), "{}", x(&app, joint));
    for _ in 0..2 {
        app.update();
    }
    assert!(close(x(&app, joint), 10.0), "the fade is over: {}", x(&app, joint));
}

#[test]
fn clips_with_bad_keyframes_are_refused_with_the_reason() {
    let bad = |times: Vec<f32>, values: Vec<Vec3>, interpolation| {
        AnimationClip::new("bad", vec![Channel::new(3, interpolation, times, Keyframes::Translation(values))]).unwrap_err().to_string()
    };
    assert!(bad(vec![0.0, 0.0], vec![Vec3::ZERO; 2], Interpolation::Linear).contains("do not increase"));
    assert!(bad(vec![0.0, 1.0], vec![Vec3::ZERO; 2], Interpolation::CubicSpline).contains("6 expected"));
    assert!(bad(vec![0.0, f32::NAN], vec![Vec3::ZERO; 2], Interpolation::Step).contains("not finite"));
    assert!(bad(vec![], vec![], Interpolation::Step).contains("node 3"));
}

#[test]
fn a_node_animated_twice_by_one_clip_is_refused() {
    let x = |v: f32| Vec3::new(v, 0.0, 0.0);
    let slide = |to: f32| Channel::new(3, Interpolation::Linear, vec![0.0, 1.0], Keyframes::Translation(vec![x(0.0), x(to)]));
    let err = AnimationClip::new("twice", vec![slide(1.0), slide(2.0)]).unwrap_err().to_string();
    assert!(err.contains("node 3") && err.contains("two channels"), "{err}");
    // A node's translation and rotation are two properties, not a repeat.
    let turn = Channel::new(3, Interpolation::Step, vec![0.0], Keyframes::Rotation(vec![Quat::IDENTITY]));
    let clip = AnimationClip::new("both", vec![slide(1.0), turn]).unwrap();
    assert!(clip.channel(3, Property::Rotation).is_some() && clip.channel(2, Property::Translation).is_none());
}

#[test]
fn retargeting_a_player_leaves_its_old_targets_where_they_were() {
    let (mut app, a, slide, _) = app();
    let b = app.world.spawn(Transform::IDENTITY).id();
    let player = app.world.spawn((AnimationPlayer::new(slide), AnimationTargets(vec![Some(a)]))).id();
    app.update();
    assert!(close(x(&app, a), 0.25));
    app.world.get_mut::<AnimationTargets>(player).unwrap().0 = vec![Some(b)];
    app.update();
    app.update();
    assert!(close(x(&app, b), 0.75), "the new target follows the clip: {}", x(&app, b));
    assert!(close(x(&app, a), 0.25), "the old one stays: {}", x(&app, a));
}

#[test]
fn morph_weights_follow_the_clip_and_blend_in_a_cross_fade() {
    let (mut app, _, _, _) = app();
    let face = app.world.spawn((Transform::IDENTITY, MorphWeights(vec![0.0, 0.0]))).id();
    let weights = |values: Vec<f32>, times: Vec<f32>| {
        AnimationClip::new("w", vec![Channel::new(0, Interpolation::Linear, times, Keyframes::Weights { targets: 2, values })]).unwrap()
    };
    let mut clips = app.world.resource_mut::<Assets<AnimationClip>>();
    let (open, shut) = (clips.add(weights(vec![0.0, 1.0, 1.0, 0.0], vec![0.0, 2.0])), clips.add(weights(vec![0.0, 0.0], vec![0.0])));
    let player = app.world.spawn((AnimationPlayer::new(open), AnimationTargets(vec![Some(face)]))).id();
    app.update();
    assert_eq!(app.world.get::<MorphWeights>(face).unwrap().0, vec![0.125, 0.875]);
    // Half way through a fade to `shut` (all zero), `open` at 0.5 s: half of (0.25, 0.75).
    app.world.get_mut::<AnimationPlayer>(player).unwrap().cross_fade(shut, 0.5);
    app.update();
    let w = &app.world.get::<MorphWeights>(face).unwrap().0;
    assert!(close(w[0], 0.125) && close(w[1], 0.375), "{w:?}");
    // Once the fade is over and the pose holds, the weights are not flagged changed again.
    for _ in 0..2 {
        app.update();
    }
    assert_eq!(app.world.get::<MorphWeights>(face).unwrap().0, vec![0.0, 0.0]);
    let before = app.world.entity(face).get_ref::<MorphWeights>().unwrap().last_changed();
    app.update();
    assert_eq!(app.world.entity(face).get_ref::<MorphWeights>().unwrap().last_changed(), before);
}
