//! glTF animations: each channel's sampler read into an [`AnimationClip`] over node indices
//! (translations, rotations, scales and morph weights; step, linear and cubic-spline).

use super::*;
use crate::animation::{Channel, Interpolation, Keyframes};
use ::gltf::animation::{Interpolation as GltfInterpolation, Property};

fn label(animation: &::gltf::Animation<'_>, file: &Path) -> String {
    match animation.name() {
        Some(name) => format!("'{name}' (#{}) in {}", animation.index(), file.display()),
        None => format!("#{} in {}", animation.index(), file.display()),
    }
}

/// Reads `accessor` as floats after checking its shape: `dimensions`, and float or (when
/// `normalized_ok`) a normalised integer type.
fn read_floats(
    accessor: &Accessor<'_>,
    buffers: &[Vec<u8>],
    name: &str,
    what: &str,
    dimensions: Dimensions,
    normalized_ok: bool,
) -> Result<Vec<f32>, GltfError> {
    let ok_type = is_float(accessor.data_type(), accessor.normalized()) || (normalized_ok && accessor.normalized());
    if accessor.dimensions() != dimensions || !ok_type {
        return Err(GltfError::Animation {
            animation: name.to_owned(),
            reason: format!("{what} is {}, not {dimensions:?} floats", describe_accessor(accessor)),
        });
    }
    Ok(read_accessor(accessor, buffers, name, what)?.into_iter().map(|v| v as f32).collect())
}

/// Loads every animation as a clip whose channels target node indices.
pub(super) fn load_animations(document: &Document, buffers: &[Vec<u8>], file: &Path) -> Result<Vec<AnimationClip>, GltfError> {
    let mut clips = Vec::with_capacity(document.animations().len());
    for animation in document.animations() {
        let name = label(&animation, file);
        let mut channels = Vec::new();
        for channel in animation.channels() {
            let sampler = channel.sampler();
            let target = channel.target();
            let what = |s: &str| format!("channel {} {s}", channel.index());
            let times = read_floats(&sampler.input(), buffers, &name, &what("input"), Dimensions::Scalar, false)?;
            let interpolation = match sampler.interpolation() {
                GltfInterpolation::Step => Interpolation::Step,
                GltfInterpolation::Linear => Interpolation::Linear,
                GltfInterpolation::CubicSpline => Interpolation::CubicSpline,
            };
            let output = sampler.output();
            let vec3s = |v: Vec<f32>| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
            let keyframes = match target.property() {
                Property::Translation => {
                    Keyframes::Translation(vec3s(read_floats(&output, buffers, &name, &what("output"), Dimensions::Vec3, false)?))
                }
                Property::Scale => Keyframes::Scale(vec3s(read_floats(&output, buffers, &name, &what("output"), Dimensions::Vec3, false)?)),
                Property::Rotation => {
                    let v = read_floats(&output, buffers, &name, &what("output"), Dimensions::Vec4, true)?;
                    Keyframes::Rotation(v.chunks_exact(4).map(|c| Quat::from_xyzw(c[0], c[1], c[2], c[3])).collect())
                }
                Property::MorphTargetWeights => {
                    let values = read_floats(&output, buffers, &name, &what("output"), Dimensions::Scalar, true)?;
                    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                    let keys = times.len() * per_key;
                    if keys == 0 || !values.len().is_multiple_of(keys) {
                        return Err(GltfError::Animation {
                            animation: name.clone(),
                            reason: format!("{}: {} weights do not divide into {} keyframes", what("output"), values.len(), times.len()),
                        });
                    }
                    Keyframes::Weights { targets: values.len() / keys, values }
                }
            };
            channels.push(Channel::new(target.node().index(), interpolation, times, keyframes));
        }
        let title = animation.name().map_or_else(|| format!("animation {}", animation.index()), str::to_owned);
        let clip =
            AnimationClip::new(title, channels).map_err(|e| GltfError::Animation { animation: name.clone(), reason: e.to_string() })?;
        clips.push(clip);
    }
    Ok(clips)
}
