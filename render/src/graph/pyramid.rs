//! Depth pyramids (`shaders/include/depth_pyramid.glsl`): their sizes and the dispatches that
//! build them, shared by GPU culling's occlusion test (`crate::culling`) and screen-space
//! reflections' ray march (`crate::reflections`).

use ash::vk;

use crate::graph::pass::PassContext;
use crate::layout::{HIZ_LEVELS_PER_DISPATCH, HIZ_MAX_LEVELS};

// An 8×8 workgroup's block halves three times to one texel (depth_pyramid_build.glsl).
const _: () = assert!(HIZ_LEVELS_PER_DISPATCH == 4, "the pyramid shader writes an 8×8 block and the three levels above it");

/// Records the dispatches of a depth pyramid's `levels` for `extent`, each after `bind` has bound
/// its pipeline and push constants for the first level it writes, with a barrier between them
/// (each reads the level below its first). GPU culling's pyramid and screen-space reflections'
/// share it: 3 dispatches at 1080p instead of one a level (11), whose binds and barriers cost
/// the CPU 1.5 µs each on NVIDIA's driver.
pub fn dispatch_pyramid(p: &PassContext, extent: vk::Extent2D, levels: u32, bind: impl Fn(&PassContext, u32)) {
    // Each dispatch writes `HIZ_LEVELS_PER_DISPATCH` levels and reads the one below its first.
    for (i, first) in (0..levels).step_by(HIZ_LEVELS_PER_DISPATCH as usize).enumerate() {
        if i > 0 {
            p.compute_to_compute();
        }
        let shift = first + 1;
        let (w, h) = (extent.width.div_ceil(1 << shift).max(1), extent.height.div_ceil(1 << shift).max(1));
        bind(p, first);
        p.cmd.dispatch(w.div_ceil(8), h.div_ceil(8), 1);
    }
}

/// Levels of a depth pyramid for `extent` (`shaders/include/depth_pyramid.glsl`): down to the
/// first 1×1 level, where `shaders/include/depth_pyramid_build.glsl` stops too.
pub fn hiz_levels(extent: vk::Extent2D) -> u32 {
    let mut levels = 1;
    while levels < HIZ_MAX_LEVELS && (extent.width.div_ceil(1 << levels) > 1 || extent.height.div_ceil(1 << levels) > 1) {
        levels += 1;
    }
    levels
}

/// Words of a depth pyramid's `levels` for `extent` (`shaders/include/depth_pyramid.glsl`).
pub fn hiz_words(extent: vk::Extent2D, levels: u32) -> u64 {
    (0..levels).map(|l| extent.width.div_ceil(1 << (l + 1)).max(1) as u64 * extent.height.div_ceil(1 << (l + 1)).max(1) as u64).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pyramid_halves_down_to_one_texel() {
        let e = |width, height| vk::Extent2D { width, height };
        assert_eq!(hiz_levels(e(1, 1)), 1);
        assert_eq!(hiz_levels(e(2, 2)), 1, "level 0 is 1×1");
        assert_eq!(hiz_levels(e(5, 3)), 3, "3×2, 2×1, 1×1");
        assert_eq!(hiz_words(e(5, 3), 3), 6 + 2 + 1);
        assert_eq!(hiz_levels(e(1920, 1080)), 11);
    }
}
