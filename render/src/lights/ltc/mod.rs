//! The linearly transformed cosines of our GGX specular lobe: what area lights shade their
//! specular term with (Heitz, Dupuy, Hill and Neubelt 2016, "Real-Time Polygonal-Light Shading
//! with Linearly Transformed Cosines", §5 and the tables of its code; issue 52, item 1; not a
//! technique of the seeds, whose lights are points).
//!
//! For each perceptual roughness and view angle, [`table`] holds the inverse of the matrix M
//! that turns the clamped cosine into the best match of the lobe D·V·(n·l) of `brdf.glsl`, and
//! the lobe's magnitude as the split sum's scale and bias of F0 (Schlick's Fresnel integrated
//! with it). `shaders/include/area_lights.glsl` transforms a light's polygon by M⁻¹, integrates
//! the cosine over it exactly (the diffuse term's edge integral) and scales by the magnitude.
//! The table is fitted offline by `render/examples/ltc_fit.rs` (its docs say how) and reaches
//! the shaders as a built-in bindless texture, [`TEXTURE_LTC`](crate::layout::TEXTURE_LTC), fetched texel by texel: as a
//! GLSL constant array it cost lavapipe 270 s of compilation in every pipeline that shades
//! lights (docs/experiments/area-lights-ltc-table.md).
//!
//! The texture is `2 × LTC_SIZE` texels wide and [`LTC_SIZE`] high, RGBA32F: row `r` is
//! perceptual roughness `r / (LTC_SIZE − 1)` (row 0 repeats row 1: shading clamps roughness to
//! 0.045, between rows 1 and 2),
//! column `c < LTC_SIZE` is √(1 − n·v) = `c / (LTC_SIZE − 1)` and holds (a, b, c, d) of
//! M⁻¹ = [[a, 0, b], [0, c, 0], [d, 0, 1]] in the shading frame (x along the view's tangent, z
//! the normal); column `LTC_SIZE + c` holds the magnitude's (scale, bias, 0, 0).

mod table;

use ash::vk;

use crate::layout::LTC_SIZE;
use crate::scene::TextureData;

const _: () = assert!(table::LTC_TABLE.len() == (LTC_SIZE * LTC_SIZE) as usize, "the fitted table has LTC_SIZE² cells");

/// The fitted cells, row after row (rows by roughness, columns by √(1 − n·v)): M⁻¹'s (a, b, c,
/// d), then the lobe's scale and bias of F0.
pub fn table() -> &'static [[f32; 6]] {
    &table::LTC_TABLE
}

/// The table as the texture [`TEXTURE_LTC`](crate::layout::TEXTURE_LTC) holds (the module docs give its layout).
pub fn texture() -> TextureData {
    let size = LTC_SIZE as usize;
    let mut texels = vec![[0.0f32; 4]; 2 * size * size];
    for (i, cell) in table::LTC_TABLE.iter().enumerate() {
        let (row, column) = (i / size, i % size);
        texels[row * 2 * size + column] = [cell[0], cell[1], cell[2], cell[3]];
        texels[row * 2 * size + size + column] = [cell[4], cell[5], 0.0, 0.0];
    }
    TextureData {
        width: 2 * LTC_SIZE,
        height: LTC_SIZE,
        format: vk::Format::R32G32B32A32_SFLOAT,
        mips: vec![bytemuck::cast_slice(&texels).to_vec()],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roughest lobe seen from above is nearly the cosine itself (M close to a uniform
    /// scale), and every lobe's magnitude is a share of the light: the fit is the one the docs
    /// describe, not a table of another layout.
    #[test]
    fn the_table_is_the_fitted_lobe() {
        let size = LTC_SIZE as usize;
        let roughest_from_above = table()[(size - 1) * size];
        assert!((roughest_from_above[0] - roughest_from_above[2]).abs() < 0.01 && roughest_from_above[1].abs() < 0.01);
        // The GGX lobe of alpha 1 seen from above reflects 0.307 (integrated by hand).
        assert!((roughest_from_above[4] + roughest_from_above[5] - 0.307).abs() < 0.01, "{roughest_from_above:?}");
        for cell in table() {
            assert!(cell.iter().all(|x| x.is_finite()));
            assert!(cell[4] >= 0.0 && cell[5] >= 0.0 && cell[4] + cell[5] <= 1.01, "{cell:?}");
        }
    }
}
