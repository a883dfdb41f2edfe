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

/// Where a time falls among a channel's keyframes: the keyframes around it, the fraction of
/// the way from the first to the second, and the interval's length in seconds.
#[derive(Clone, Copy, Debug)]
pub(super) struct Keys {
    a: usize,
    b: usize,
    s: f32,
    dt: f32,
}

impl Channel {
    /// The keyframes around `t`. Before the first keyframe the first holds; after the last,
    /// the last. The keyframe the channel's mean rate puts `t` after is tried first (right at
    /// once for evenly spaced keyframes, as exporters write them), then a binary search.
    pub(super) fn keys(&self, t: f32) -> Keys {
        let times = &self.times;
        let last = times.len() - 1;
        if t <= times[0] {
            return Keys { a: 0, b: 0, s: 0.0, dt: 0.0 };
        }
        if t >= times[last] {
            return Keys { a: last, b: last, s: 0.0, dt: 0.0 };
        }
        let guess = (((t - times[0]) * self.rate) as usize).min(last - 1);
        let b = if times[guess] <= t && t < times[guess + 1] { guess + 1 } else { times.partition_point(|&k| k <= t) };
        let a = b - 1;
        let dt = times[b] - times[a];
        Keys { a, b, s: (t - times[a]) / dt, dt }
    }
}

/// The shortest arc between two rotation keyframes, for spherical interpolation without an
/// inverse cosine or a normalisation per sample: its angle in 4D, the reciprocal of its sine,
/// and whether the second keyframe is negated to take the short way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Arc {
    angle: f32,
    inv_sin: f32,
    flip: bool,
}

impl Arc {
    /// The arc from unit `a` to unit `b` (or to `-b`, whichever is shorter). The angle comes
    /// from the chord and its complement, `2 atan2(|a - b|, |a + b|)`, which stays accurate
    /// where the inverse cosine of the dot product does not (keyframes a degree apart).
    pub(super) fn between(a: Quat, b: Quat) -> Self {
        let flip = a.dot(b) < 0.0;
        let (a, b) = (Vec4::from(a), if flip { -Vec4::from(b) } else { Vec4::from(b) });
        let angle = 2.0 * (a - b).length().atan2((a + b).length());
        Self { angle, inv_sin: 1.0 / angle.sin(), flip }
    }

    /// `a` turned the fraction `s` of the way along the arc to `b`: slerp,
    /// `(sin((1 - s)θ) a + sin(sθ) b) / sin θ`, a unit quaternion for unit keyframes; linear
    /// weights (and a normalisation) where the arc is too short for the sines to tell apart.
    fn slerp(self, a: Quat, b: Quat, s: f32) -> Quat {
        let b = if self.flip { -Vec4::from(b) } else { Vec4::from(b) };
        if self.angle < 1e-3 {
            return Quat::from_vec4((Vec4::from(a) * (1.0 - s) + b * s).normalize());
        }
        let (wa, wb) = (sin_to_right_angle((1.0 - s) * self.angle), sin_to_right_angle(s * self.angle));
        Quat::from_vec4((Vec4::from(a) * wa + b * wb) * self.inv_sin)
    }
}

/// `sin x` for `0 ≤ x ≤ π/2` (the angles of an arc between unit quaternions on the short side
/// and its fractions): the Taylor polynomial to `x¹¹`, whose error there is below 6e-8, about
/// an f32's rounding; several times cheaper than the library's full-range `sinf`, which
/// animation calls twice per rotation per frame.
fn sin_to_right_angle(x: f32) -> f32 {
    let x2 = x * x;
    let series = 1.0 / 39_916_800.0;
    let series = 1.0 / 362_880.0 - x2 * series;
    let series = 1.0 / 5_040.0 - x2 * series;
    let series = 1.0 / 120.0 - x2 * series;
    let series = 1.0 / 6.0 - x2 * series;
    x * (1.0 - x2 * series)
}

/// Hermite basis at `s` for (value 0, tangent 0 × dt, value 1, tangent 1 × dt).
fn hermite(s: f32) -> [f32; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2]
}

/// Interpolates between the keyframes `keys` names in a channel whose entries are read by
/// `get` (`get(i)` is entry `i`: for cubic splines keyframe `k` has entries `3k` (in-tangent),
/// `3k+1` (value) and `3k+2` (out-tangent)).
fn interpolate<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>>(
    interpolation: Interpolation,
    get: impl Fn(usize) -> T,
    Keys { a, b, s, dt }: Keys,
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

/// A translation or scale channel's value at `keys`.
pub(super) fn vec3_at(interpolation: Interpolation, values: &[Vec3], keys: Keys) -> Vec3 {
    interpolate(interpolation, |i| values[i], keys, Vec3::lerp)
}

/// A rotation channel's unit rotation at `keys`: shortest-path slerp between linear keyframes
/// (along the channel's precomputed `arcs`), the renormalised spline between cubic ones.
pub(super) fn rotation_at(interpolation: Interpolation, values: &[Quat], arcs: &[Arc], keys: Keys) -> Quat {
    if interpolation == Interpolation::Linear && keys.a != keys.b {
        return arcs[keys.a].slerp(values[keys.a], values[keys.b], keys.s);
    }
    Quat::from_vec4(interpolate(interpolation, |i| Vec4::from(values[i]), keys, Vec4::lerp)).normalize()
}

impl Channel {
    /// Its value at `keys`; a morph weight channel answers [`Sampled::Weights`] and gives its
    /// weights one at a time ([`Channel::weight_at`]).
    fn value_at(&self, keys: Keys) -> Sampled {
        let mode = self.interpolation;
        match &self.keyframes {
            Keyframes::Translation(v) => Sampled::Translation(vec3_at(mode, v, keys)),
            Keyframes::Scale(v) => Sampled::Scale(vec3_at(mode, v, keys)),
            Keyframes::Rotation(v) => Sampled::Rotation(rotation_at(mode, v, &self.arcs, keys)),
            Keyframes::Weights { .. } => Sampled::Weights,
        }
    }

    /// Morph target `target`'s weight at `keys` (`None` beyond the channel's targets, or for a
    /// channel of another property).
    pub(super) fn weight_at(&self, keys: Keys, target: usize) -> Option<f32> {
        let Keyframes::Weights { targets, values } = &self.keyframes else { return None };
        // Entry i of target j: values[i * targets + j].
        (target < *targets).then(|| interpolate(self.interpolation, |i| values[i * targets + target], keys, |a, b, s| a + (b - a) * s))
    }
}

/// Samples `channel` at `t` seconds; morph weights go to `weights` (resized to the target
/// count; no allocation once it has that size).
pub fn sample_channel(channel: &Channel, t: f32, weights: &mut Vec<f32>) -> Sampled {
    let keys = channel.keys(t);
    if let Keyframes::Weights { targets, .. } = channel.keyframes {
        weights.resize(targets, 0.0);
        for (target, out) in weights.iter_mut().enumerate() {
            *out = channel.weight_at(keys, target).unwrap_or(0.0);
        }
    }
    channel.value_at(keys)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, times: Vec<f32>, keyframes: Keyframes) -> Channel {
        Channel::new(0, interpolation, times, keyframes)
    }

    /// How far apart two rotations are as unit quaternions (q and -q being one rotation),
    /// component by component: unlike an angle from an inverse cosine, exact near zero.
    fn apart(a: Quat, b: Quat) -> f32 {
        (Vec4::from(a) - Vec4::from(b)).length().min((Vec4::from(a) + Vec4::from(b)).length())
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
    fn the_short_sine_matches_the_library_to_the_right_angle() {
        for i in 0..=1000 {
            let x = i as f32 / 1000.0 * std::f32::consts::FRAC_PI_2;
            assert!((sin_to_right_angle(x) - x.sin()).abs() < 2e-7, "{x}: {} vs {}", sin_to_right_angle(x), x.sin());
        }
    }

    #[test]
    fn linear_rotations_match_glam_slerp() {
        // Keyframes 20° to 170° apart, some of them on the far side (negated).
        let keys: Vec<Quat> = (0..8)
            .map(|i| {
                let q = Quat::from_axis_angle(Vec3::new(1.0, i as f32, 2.0).normalize(), i as f32 * i as f32 * 0.17);
                if i % 3 == 2 { -q } else { q }
            })
            .collect();
        let c = channel(Interpolation::Linear, (0..8).map(|i| i as f32).collect(), Keyframes::Rotation(keys.clone()));
        for i in 0..70 {
            let t = i as f32 * 0.1;
            let Sampled::Rotation(q) = sample_channel(&c, t, &mut Vec::new()) else { panic!() };
            let k = (t as usize).min(6);
            let expected = keys[k].slerp(keys[k + 1], t - k as f32);
            assert!(apart(q, expected) < 1e-5, "at {t}: {q} vs {expected}");
        }
    }

    #[test]
    fn rotations_slerp_along_the_shortest_path() {
        let a = Quat::IDENTITY;
        // 270° about Y is the same orientation as −90°: the short way is −45° at the middle.
        let b = Quat::from_rotation_y(270f32.to_radians());
        let c = channel(Interpolation::Linear, vec![0.0, 1.0], Keyframes::Rotation(vec![a, b]));
        let Sampled::Rotation(q) = sample_channel(&c, 0.5, &mut Vec::new()) else { panic!() };
        let expected = Quat::from_rotation_y(-45f32.to_radians());
        assert!(apart(q, expected) < 1e-6, "{q} vs {expected}");
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
    fn cubic_rotations_keep_their_tangents() {
        // From identity to 90° about Y over 2 s, with an out-tangent of length 0.3 (not a unit
        // quaternion: normalising it would change the curve). At s = 0.5, h = (0.5, 0.125,
        // 0.5, -0.125) and the tangents scale by dt = 2.
        let (v0, v1) = (Quat::IDENTITY, Quat::from_rotation_y(std::f32::consts::FRAC_PI_2));
        let out0 = Vec4::new(0.0, 0.3, 0.0, 0.0);
        let keys = vec![Quat::IDENTITY, v0, Quat::from_vec4(out0), Quat::from_vec4(Vec4::ZERO), v1, Quat::IDENTITY];
        let c = channel(Interpolation::CubicSpline, vec![0.0, 2.0], Keyframes::Rotation(keys));
        let Sampled::Rotation(q) = sample_channel(&c, 1.0, &mut Vec::new()) else { panic!() };
        let expected = Quat::from_vec4((Vec4::from(v0) * 0.5 + out0 * (0.125 * 2.0) + Vec4::from(v1) * 0.5).normalize());
        assert!(apart(q, expected) < 1e-6, "{q} vs {expected}");
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
