//! Rec. 709 luminance, the one definition every operator that weighs light by brightness uses
//! (ITU-R BT.709 primaries, the same weights as `Luminance(weights: Rec709)`). A leaf below
//! `maths`, `formats` and the operators, like [`crate::cpu`], so that a file format can weigh
//! channels without depending on the mathematics.

/// The Rec. 709 luminance weights of R, G, B: the Y row of BT.709's RGB -> XYZ matrix, to the
/// 4 decimals ITU-R BT.709-6 (item 3.2) and sRGB (IEC 61966-2-1) give. Every luminance in the
/// crate uses these (or [`REC709_F32`]); the one place they are written.
pub const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// [`REC709`] in f32, for luminance summed in f32. Each cast gives the same bits as the f32
/// literal (0.2126f32 etc.: no double rounding for these three; a test checks).
pub const REC709_F32: [f32; 3] = [REC709[0] as f32, REC709[1] as f32, REC709[2] as f32];

/// `Y = 0.2126 R + 0.7152 G + 0.0722 B`, summed in f64.
#[inline]
pub fn rec709_luminance(rgb: [f32; 3]) -> f64 {
    REC709[0] * rgb[0] as f64 + REC709[1] * rgb[1] as f64 + REC709[2] * rgb[2] as f64
}

/// `Y = 0.2126 R + 0.7152 G + 0.0722 B` in f32, as `Luminance(weights: Rec709)` computes each
/// pixel (the luminance image a distribution is built from).
#[inline]
pub fn rec709_luminance_f32(rgb: [f32; 3]) -> f32 {
    let ([r, g, b], [wr, wg, wb]) = (rgb, REC709_F32);
    wr * r + wg * g + wb * b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_f32_weights_are_the_f32_literals() {
        let literals = [0.2126f32, 0.7152f32, 0.0722f32];
        assert_eq!(REC709_F32.map(f32::to_bits), literals.map(f32::to_bits));
        assert!((REC709.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }
}
