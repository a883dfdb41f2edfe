//! glTF animations: each channel's sampler read into an [`AnimationClip`] over node indices
//! (translations, rotations, scales and morph weights; step, linear and cubic-spline). A channel
//! that cannot be sampled is dropped and the rest of its clip plays; keyframes whose values are
//! not finite, or rotations of zero length, are dropped from their channel; one [`GltfFault`]
//! each (see the parent module's docs).

use super::*;
use crate::animation::{Channel, Interpolation, Keyframes, Property};
use ::gltf::animation::{Interpolation as GltfInterpolation, Property as GltfProperty};

/// Reads `accessor` as floats after checking its shape: `dimensions`, and float or (when
/// `normalized_ok`) a normalised integer type.
fn read_floats(
    accessor: &Accessor<'_>,
    buffers: &[Vec<u8>],
    name: &str,
    what: &str,
    dimensions: Dimensions,
    normalized_ok: bool,
) -> Result<Vec<f32>, String> {
    let ok_type = is_float(accessor.data_type(), accessor.normalized()) || (normalized_ok && accessor.normalized());
    if accessor.dimensions() != dimensions || !ok_type {
        return Err(format!("its {what} is {}, not {dimensions:?} floats", describe_accessor(accessor)));
    }
    match read_accessor(accessor, buffers, name, what) {
        Ok(values) => Ok(values.into_iter().map(|v| v as f32).collect()),
        Err(GltfError::BadAccessor { reason, .. }) => Err(format!("its {what}: {reason}")),
        Err(error) => Err(error.to_string()),
    }
}

/// A channel read from the file, with the faults repaired in it (keyframes dropped).
struct ReadChannel {
    channel: Channel,
    repairs: Vec<(GltfFaultKind, String, String)>,
}

type Refusal = (GltfFaultKind, String);

/// Reads one channel, or says why it cannot be sampled.
fn read_channel(channel: &::gltf::animation::Channel<'_>, buffers: &[Vec<u8>], name: &str) -> Result<ReadChannel, Refusal> {
    let bad = |reason: String| (GltfFaultKind::BadChannel, reason);
    let sampler = channel.sampler();
    let target = channel.target();
    let mut times = read_floats(&sampler.input(), buffers, name, "input", Dimensions::Scalar, false).map_err(bad)?;
    if times.is_empty() {
        return Err(bad("it has no keyframes".into()));
    }
    if let Some(i) = times.iter().position(|t| !t.is_finite()) {
        return Err((GltfFaultKind::NonFiniteKeyframes, format!("keyframe {i}'s time is not finite")));
    }
    if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
        let problem = format!("keyframe times do not increase at keyframe {} ({} after {})", i + 1, times[i + 1], times[i]);
        return Err((GltfFaultKind::KeyframeTimesNotIncreasing, problem));
    }
    let interpolation = match sampler.interpolation() {
        GltfInterpolation::Step => Interpolation::Step,
        GltfInterpolation::Linear => Interpolation::Linear,
        GltfInterpolation::CubicSpline => Interpolation::CubicSpline,
    };
    let cubic = interpolation == Interpolation::CubicSpline;
    let per_key = if cubic { 3 } else { 1 };
    let output = sampler.output();
    // Values as one flat list; `width` of them per entry, `per_key` entries per keyframe.
    let (values, width) = match target.property() {
        GltfProperty::Translation | GltfProperty::Scale => {
            (read_floats(&output, buffers, name, "output", Dimensions::Vec3, false).map_err(bad)?, 3)
        }
        GltfProperty::Rotation => (read_floats(&output, buffers, name, "output", Dimensions::Vec4, true).map_err(bad)?, 4),
        GltfProperty::MorphTargetWeights => {
            let values = read_floats(&output, buffers, name, "output", Dimensions::Scalar, true).map_err(bad)?;
            let targets = target.node().mesh().and_then(|m| m.primitives().next()).map(|p| p.morph_targets().len()).filter(|&t| t > 0);
            let width = match targets {
                Some(targets) => targets,
                // Without the mesh's count, the values must at least divide into the keyframes.
                None if !values.is_empty() && values.len().is_multiple_of(times.len() * per_key) => values.len() / (times.len() * per_key),
                None => 1,
            };
            (values, width)
        }
    };
    let entries = values.len() / width;
    if entries * width != values.len() || entries != times.len() * per_key {
        let what =
            if width > 1 && target.property() == GltfProperty::MorphTargetWeights { format!(" of {width} weights") } else { String::new() };
        if cubic && entries * width == values.len() && entries == times.len() {
            let problem = format!("its cubic-spline sampler has {entries} values{what} for {} keyframes: no tangents", times.len());
            return Err((GltfFaultKind::CubicSplineWithoutTangents, problem));
        }
        let problem = format!(
            "its sampler has {} output values for {} input keyframes ({} expected with {interpolation:?} interpolation)",
            values.len(),
            times.len(),
            times.len() * per_key * width
        );
        return Err((GltfFaultKind::SamplerCountMismatch, problem));
    }
    // Keyframes with a value that is not finite, and rotations of zero length, are dropped.
    let block = per_key * width;
    let value_at = if cubic { width } else { 0 };
    let mut non_finite = Vec::new();
    let mut zero_rotations = Vec::new();
    for (k, values) in values.chunks_exact(block).enumerate() {
        if values.iter().any(|v| !v.is_finite()) {
            non_finite.push(k);
        } else if target.property() == GltfProperty::Rotation && Vec4::from_slice(&values[value_at..value_at + 4]).length() < 1e-6 {
            zero_rotations.push(k);
        }
    }
    let mut repairs = Vec::new();
    let keyframe_list = |keys: &[usize]| {
        let shown: Vec<String> = keys.iter().take(8).map(usize::to_string).collect();
        format!("{}{}", shown.join(", "), if keys.len() > 8 { ", …" } else { "" })
    };
    let dropped = non_finite.len() + zero_rotations.len();
    let everything = dropped == times.len();
    for (keys, kind, what) in [
        (&non_finite, GltfFaultKind::NonFiniteKeyframes, "a value that is not finite"),
        (&zero_rotations, GltfFaultKind::ZeroRotationKeyframes, "a rotation of zero length"),
    ] {
        if keys.is_empty() {
            continue;
        }
        let problem = format!("{} of {} keyframes ({}) hold {what}", keys.len(), times.len(), keyframe_list(keys));
        if everything {
            // One fault for a channel with nothing left: the first kind found.
            return Err((kind, format!("{problem}, and no keyframe is left")));
        }
        repairs.push((kind, problem, "those keyframes are dropped and the channel plays the others".to_owned()));
    }
    let mut values = values;
    if dropped > 0 {
        let keep: Vec<bool> = (0..times.len()).map(|k| !non_finite.contains(&k) && !zero_rotations.contains(&k)).collect();
        let mut k = 0;
        times.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        values = values.chunks_exact(block).zip(&keep).filter(|(_, keep)| **keep).flat_map(|(v, _)| v.iter().copied()).collect();
    }
    let keyframes = match target.property() {
        GltfProperty::Translation => Keyframes::Translation(values.chunks_exact(3).map(Vec3::from_slice).collect()),
        GltfProperty::Scale => Keyframes::Scale(values.chunks_exact(3).map(Vec3::from_slice).collect()),
        GltfProperty::Rotation => Keyframes::Rotation(values.chunks_exact(4).map(Quat::from_slice).collect()),
        GltfProperty::MorphTargetWeights => Keyframes::Weights { targets: width, values },
    };
    let channel = Channel::new(target.node().index(), interpolation, times, keyframes);
    channel.check().map_err(|e| bad(e.to_string()))?;
    Ok(ReadChannel { channel, repairs })
}

/// Loads every animation as a clip whose channels target node indices. A channel that cannot
/// be sampled is left out of its clip, with one fault.
pub(super) fn load_animations(document: &Document, buffers: &[Vec<u8>], file: &Path, faults: &mut Faults) -> Vec<AnimationClip> {
    let mut clips = Vec::with_capacity(document.animations().len());
    for animation in document.animations() {
        let name = match animation.name() {
            Some(name) => format!("animation '{name}' (#{}) in {}", animation.index(), file.display()),
            None => format!("animation #{} in {}", animation.index(), file.display()),
        };
        let mut channels: Vec<Channel> = Vec::new();
        let mut animated: HashMap<(usize, Property), usize> = HashMap::new();
        for channel in animation.channels() {
            let part = || GltfPart::Channel {
                animation: animation.index(),
                animation_name: animation.name().map(str::to_owned),
                channel: channel.index(),
                sampler: channel.sampler().index(),
            };
            const DROPPED: &str = "the channel is dropped and the rest of the clip plays";
            let what = format!("{name} channel {}", channel.index());
            match read_channel(&channel, buffers, &what) {
                Ok(ReadChannel { channel: read, repairs }) => {
                    for (kind, problem, fallback) in repairs {
                        faults.push(part(), kind, problem, fallback);
                    }
                    let key = (read.target(), read.keyframes().property());
                    if let Some(first) = animated.get(&key) {
                        let problem = format!("node #{}'s {:?} is already animated by channel {first}", key.0, key.1);
                        faults.push(part(), GltfFaultKind::BadChannel, problem, DROPPED);
                        continue;
                    }
                    animated.insert(key, channel.index());
                    channels.push(read);
                }
                Err((kind, problem)) => faults.push(part(), kind, problem, DROPPED),
            }
        }
        let title = animation.name().map_or_else(|| format!("animation {}", animation.index()), str::to_owned);
        // Every channel was checked above, so the clip is made; should a check of the clip's own
        // refuse it, the clip stays in its place (indices are the file's), empty.
        let clip = AnimationClip::new(title.clone(), channels).unwrap_or_else(|error| {
            let part = GltfPart::Channel {
                animation: animation.index(),
                animation_name: animation.name().map(str::to_owned),
                channel: 0,
                sampler: 0,
            };
            faults.push(part, GltfFaultKind::BadChannel, error.to_string(), "the clip is empty");
            AnimationClip::empty(title)
        });
        clips.push(clip);
    }
    clips
}
