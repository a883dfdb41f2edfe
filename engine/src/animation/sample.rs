//! Sampling a channel at a time (glTF 2.0 Appendix C): the keyframe interval by binary search,
//! then step, linear (shortest-path slerp for rotations) or cubic Hermite interpolation with
//! tangents scaled by the interval's length. Before the first keyframe the first value holds;
//! after the last, the last.

use glam::{Quat, Vec3, Vec4};

use super::{Channel, Interpolation, Keyframes};

/// A channel's value at a time. Morph weights are written to the caller's buffer instead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampled {
    /// A translation.
    Translation(Vec3),
    /// A unit rotation.
    Rotation(Quat),
    /// A scale.
    Scale(Vec3),
    /// Morph weights, in the buffer passed to [`sample_channel`].
    Weights,
}

/// The keyframes around `t`: (first, second, fraction of the way from one to the other).
fn interval(times: &[f32], t: f32) -> (usize, usize, f32) {
    let last = times.len() - 1;
    if t <= times[0] {
        return (0, 0, 0.0);
    }
    if t >= times[last] {
        return (last, last, 0.0);
    }
    let next = times.partition_point(|&k| k <= t);
    let prev = next - 1;
    (prev, next, (t - times[prev]) / (times[next] - times[prev]))
}

/// Hermite basis at `s` for (value 0, tangent 0 × dt, value 1, tangent 1 × dt).
fn hermite(s: f32) -> [f32; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2]
}

/// Interpolates between keyframes `a` and `b` of a channel whose entries are read by `get`
/// (`get(i)` is entry `i`: for cubic splines keyframe `k` has entries `3k` (in-tangent), `3k+1`
/// (value) and `3k+2` (out-tangent)).
fn interpolate<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>>(
    interpolation: Interpolation,
    get: impl Fn(usize) -> T,
    (a, b, s): (usize, usize, f32),
    dt: f32,
    lerp: impl Fn(T, T, f32) -> T,
) -> T {
    match interpolation {
        Interpolation::Step => get(a),
        Interpolation::Linear if a == b => get(a),
        Interpolation::Linear => lerp(get(a), get(b), s),
        Interpolation::CubicSpline if a == b => get(3 * a + 1),
        Interpolation::CubicSpline => {
            let h = hermite(s);
            get(3 * a + 1) * h[0] + get(3 * a + 2) * (h[1] * dt) + get(3 * b + 1) * h[2] + get(3 * b) * (h[3] * dt)
        }
    }
}

/// Samples `channel` at `t` seconds; morph weights go to `weights` (resized to the target
/// count; no allocation once it has that size).
pub fn sample_channel(channel: &Channel, t: f32, weights: &mut Vec<f32>) -> Sampled {
    let keys = interval(&channel.times, t);
    let dt = channel.times[keys.1] - channel.times[keys.0];
    let mode = channel.interpolation;
    match &channel.keyframes {
        Keyframes::Translation(v) => Sampled::Translation(interpolate(mode, |i| v[i], keys, dt, Vec3::lerp)),
        Keyframes::Scale(v) => Sampled::Scale(interpolate(mode, |i| v[i], keys, dt, Vec3::lerp)),
        Keyframes::Rotation(v) => {
            // Quaternions as vectors for the spline; slerp (shortest path) for linear.
            let q =
                interpolate(mode, |i| Vec4::from(v[i]), keys, dt, |a, b, s| Vec4::from(Quat::from_vec4(a).slerp(Quat::from_vec4(b), s)));
            Sampled::Rotation(Quat::from_vec4(q).normalize())
        }
        Keyframes::Weights { targets, values } => {
            let n = *targets;
            weights.resize(n, 0.0);
            for (target, out) in weights.iter_mut().enumerate() {
                // Entry i of target j: values[i * n + j].
                *out = interpolate(mode, |i| values[i * n + target], keys, dt, |a, b, s| a + (b - a) * s);
            }
            Sampled::Weights
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, times: Vec<f32>, keyframes: Keyframes) -> Channel {
        Channel::new(0, interpolation, times, keyframes)
    }

    fn translation(c: &Channel, t: f32) -> Vec3 {
        match sample_channel(c, t, &mut Vec::new()) {
            Sampled::Translation(v) => v,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn step_and_linear_keyframes_sample_as_computed_by_hand() {
        let values = vec![Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 4.0, 0.0)];
        let step = channel(Interpolation::Step, vec![1.0, 2.0, 4.0], Keyframes::Translation(values.clone()));
        let linear = channel(Interpolation::Linear, vec![1.0, 2.0, 4.0], Keyframes::Translation(values));
        // Before the first and after the last keyframe: those values.
        assert_eq!(translation(&step, 0.0), Vec3::ZERO);
        assert_eq!(translation(&linear, 9.0), Vec3::new(2.0, 4.0, 0.0));
        // Step holds the earlier value; on a keyframe, that keyframe's.
        assert_eq!(translation(&step, 1.9), Vec3::ZERO);
        assert_eq!(translation(&step, 2.0), Vec3::new(2.0, 0.0, 0.0));
        // Linear: a quarter of the way from 1 s to 2 s, and half way from 2 s to 4 s.
        assert!((translation(&linear, 1.25) - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6);
        assert!((translation(&linear, 3.0) - Vec3::new(2.0, 2.0, 0.0)).length() < 1e-6);
    }

    #[test]
    fn rotations_slerp_along_the_shortest_path() {
        let a = Quat::IDENTITY;
        // 270° about Y is the same orientation as −90°: the short way is −45° at the middle.
        let b = Quat::from_rotation_y(270f32.to_radians());
        let c = channel(Interpolation::Linear, vec![0.0, 1.0], Keyframes::Rotation(vec![a, b]));
        let Sampled::Rotation(q) = sample_channel(&c, 0.5, &mut Vec::new()) else { panic!() };
        let expected = Quat::from_rotation_y(-45f32.to_radians());
        assert!(q.angle_between(expected) < 1e-4, "{q} vs {expected}");
    }

    #[test]
    fn cubic_splines_follow_the_hermite_polynomial() {
        // One dimension in x: values 0 → 1 over 2 s, out-tangent of the first 1/s, in-tangent of
        // the second 0. At s = 0.5: h = (0.5, 0.125, 0.5, -0.125); p = 0·0.5 + 1·2·0.125 +
        // 1·0.5 + 0 = 0.75.
        let x = |v: f32| Vec3::new(v, 0.0, 0.0);
        let keys = vec![x(9.0), x(0.0), x(1.0), x(0.0), x(1.0), x(9.0)];
        let c = channel(Interpolation::CubicSpline, vec![0.0, 2.0], Keyframes::Translation(keys));
        assert!((translation(&c, 1.0).x - 0.75).abs() < 1e-6, "{}", translation(&c, 1.0));
        // On and beyond the keyframes: the values, never the tangents.
        assert_eq!(translation(&c, 0.0).x, 0.0);
        assert_eq!(translation(&c, 5.0).x, 1.0);
    }

    #[test]
    fn morph_weights_interpolate_per_target() {
        let c = channel(Interpolation::Linear, vec![0.0, 1.0], Keyframes::Weights { targets: 2, values: vec![0.0, 1.0, 1.0, 0.0] });
        let mut w = Vec::new();
        assert_eq!(sample_channel(&c, 0.25, &mut w), Sampled::Weights);
        assert_eq!(w, vec![0.25, 0.75]);
        let step = channel(Interpolation::Step, vec![0.0, 1.0], Keyframes::Weights { targets: 2, values: vec![0.0, 1.0, 1.0, 0.0] });
        sample_channel(&step, 0.99, &mut w);
        assert_eq!(w, vec![0.0, 1.0]);
    }
}
