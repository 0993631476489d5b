//! The packed unsigned-float texels of `VK_FORMAT_E5B9G9R9_UFLOAT_PACK32` (rgb9e5) and
//! `VK_FORMAT_B10G11R11_UFLOAT_PACK32` (GL's `R11F_G11F_B10F`), encoded from f32 and decoded back,
//! from the Khronos Data Format Specification 1.3, sections "Shared exponent" (the
//! `EXT_texture_shared_exponent` algorithm) and "Unsigned 11-bit floating-point numbers" /
//! "Unsigned 10-bit floating-point numbers".
//!
//! **rgb9e5**: three 9-bit mantissas and one 5-bit exponent (bias B = 15, N = 9 mantissa bits), R in
//! bits 0..9, G 9..18, B 18..27, E 27..32; a channel is `m 2^(E - B - N)`. Encoding, as the
//! specification gives it: each channel clamped to [0, 65408] (65408 = 511/512 2^16 the largest
//! value; NaN -> 0), `E' = max(-B - 1, floor(log2 max_c)) + 1 + B`, `E = E' + 1` when
//! `floor(max_c / 2^(E' - B - N) + 0.5) = 2^N`, then `m = floor(c / 2^(E - B - N) + 0.5)` (round to
//! nearest). Error bound (the test sweeps it): every channel within 2^-9 of the largest channel
//! `max_c` (2^-9 x 512/511.5 when the rounding carries into the exponent), and within 2^-25
//! absolutely when `max_c < 2^-15`; small channels next to a large one lose their relative precision.
//!
//! **B10G11R11**: R in bits 0..11 and G in 11..22 are 11-bit floats (5-bit exponent, bias 15, 6-bit
//! mantissa, no sign), B in 22..32 a 10-bit float (5-bit mantissa). Largest finite values 65024
//! (R, G) and 64512 (B); values below 2^-14 are denormals `m 2^-14 / 2^M`. Rounded to nearest, ties
//! to even: relative error at most 2^-7 for R and G, 2^-6 for B (half a unit in the last place),
//! and 2^-21 (R, G) or 2^-20 (B) absolutely below 2^-14.
//!
//! Both formats store neither negatives nor NaN (and here no infinities: a texture filter would
//! spread them): the encoders clamp, and [`KtxFormat::clamps`](super::ktx2::KtxFormat::clamps)
//! says which texels were clamped so that the caller can warn once.

/// The largest rgb9e5 channel: (2^9 - 1) / 2^9 x 2^(31 - 15).
pub const RGB9E5_MAX: f32 = 65408.0;
/// The largest 11-bit unsigned float (R and G of B10G11R11): (2 - 2^-6) x 2^15.
pub const UF11_MAX: f32 = 65024.0;
/// The largest 10-bit unsigned float (B of B10G11R11): (2 - 2^-5) x 2^15.
pub const UF10_MAX: f32 = 64512.0;

const RGB9E5_BIAS: i32 = 15;
const RGB9E5_MANTISSA_BITS: i32 = 9;

/// `floor(log2 v)` of a positive f32 from its exponent bits (exact, unlike `log2().floor()` just
/// below a power of two); subnormals give -127, which the callers clamp anyway.
fn floor_log2(v: f32) -> i32 {
    ((v.to_bits() >> 23) & 0xff) as i32 - 127
}

/// A channel clamped to `[0, max]`; NaN and negatives become 0, +Inf `max`.
fn clamp_unsigned(v: f32, max: f32) -> f32 {
    if v > 0.0 {
        v.min(max)
    } else {
        0.0
    }
}

/// Encodes RGB as one rgb9e5 word (the specification's algorithm, round to nearest).
pub fn encode_rgb9e5(rgb: [f32; 3]) -> u32 {
    let c = rgb.map(|v| clamp_unsigned(v, RGB9E5_MAX));
    let max_c = c[0].max(c[1]).max(c[2]);
    if max_c == 0.0 {
        return 0;
    }
    let mut exponent = floor_log2(max_c).max(-RGB9E5_BIAS - 1) + 1 + RGB9E5_BIAS;
    let step = |e: i32| 2f64.powi(e - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    if (max_c as f64 / step(exponent) + 0.5).floor() == (1 << RGB9E5_MANTISSA_BITS) as f64 {
        exponent += 1;
    }
    let m = c.map(|v| (v as f64 / step(exponent) + 0.5).floor() as u32);
    m[0] | (m[1] << 9) | (m[2] << 18) | ((exponent as u32) << 27)
}

/// Decodes an rgb9e5 word.
pub fn decode_rgb9e5(word: u32) -> [f32; 3] {
    let scale = 2f32.powi((word >> 27) as i32 - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    [word & 0x1ff, (word >> 9) & 0x1ff, (word >> 18) & 0x1ff].map(|m| m as f32 * scale)
}

/// Encodes a value as an unsigned float of 5 exponent bits (bias 15) and `mantissa_bits`,
/// clamped to `[0, max]` first, rounded to nearest with ties to even.
fn encode_ufloat(v: f32, mantissa_bits: u32, max: f32) -> u32 {
    let v = clamp_unsigned(v, max);
    if floor_log2(v) >= -14 {
        // Normal: keep the top `mantissa_bits` of f32's 23, round on the rest; a carry out of the
        // mantissa moves into the exponent as it should (never past `max`, which is below 2^16).
        let bits = v.to_bits();
        let shift = 23 - mantissa_bits;
        let mantissa = bits & 0x7f_ffff;
        let exponent = (floor_log2(v) + 15) as u32;
        let truncated = (exponent << mantissa_bits) | (mantissa >> shift);
        let rest = mantissa & ((1 << shift) - 1);
        let half = 1 << (shift - 1);
        truncated + u32::from(rest > half || (rest == half && truncated & 1 == 1))
    } else {
        // Denormal (exponent field 0): m 2^-14 / 2^M; rounding up to 2^M gives the smallest
        // normal's bit pattern, which is right.
        (v as f64 * 2f64.powi(14 + mantissa_bits as i32)).round_ties_even() as u32
    }
}

/// Decodes an unsigned float of 5 exponent bits (bias 15) and `mantissa_bits` (finite only: the
/// encoder never writes exponent 31).
fn decode_ufloat(bits: u32, mantissa_bits: u32) -> f32 {
    let exponent = (bits >> mantissa_bits) as i32;
    let mantissa = (bits & ((1 << mantissa_bits) - 1)) as f32 / (1u32 << mantissa_bits) as f32;
    if exponent == 0 {
        mantissa * 2f32.powi(-14)
    } else {
        (1.0 + mantissa) * 2f32.powi(exponent - 15)
    }
}

/// Encodes RGB as one B10G11R11 word (R in the low bits).
pub fn encode_b10g11r11(rgb: [f32; 3]) -> u32 {
    encode_ufloat(rgb[0], 6, UF11_MAX)
        | (encode_ufloat(rgb[1], 6, UF11_MAX) << 11)
        | (encode_ufloat(rgb[2], 5, UF10_MAX) << 22)
}

/// Decodes a B10G11R11 word.
pub fn decode_b10g11r11(word: u32) -> [f32; 3] {
    [decode_ufloat(word & 0x7ff, 6), decode_ufloat((word >> 11) & 0x7ff, 6), decode_ufloat(word >> 22, 5)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` values log-uniform over `[lo, hi]`, both ends included.
    fn log_sweep(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f32> {
        (0..n).map(move |i| (lo.ln() + (hi / lo).ln() * i as f64 / (n - 1) as f64).exp() as f32)
    }

    /// The largest relative error of `encode` then `decode` over a log-uniform sweep, per channel.
    #[test]
    fn b10g11r11_rounding_error_is_half_an_ulp() {
        let (mut worst_rg, mut worst_b) = (0f64, 0f64);
        for v in log_sweep(2f64.powi(-14), UF10_MAX as f64, 200_001) {
            let back = decode_b10g11r11(encode_b10g11r11([v, v, v]));
            let rel = |got: f32| ((got as f64 - v as f64) / v as f64).abs();
            worst_rg = worst_rg.max(rel(back[0])).max(rel(back[1]));
            worst_b = worst_b.max(rel(back[2]));
        }
        // The specification's bound, half a unit in the last place, and nearly reached.
        assert!(worst_rg <= 2f64.powi(-7) && worst_rg > 0.95 * 2f64.powi(-7), "R, G: {worst_rg}");
        assert!(worst_b <= 2f64.powi(-6) && worst_b > 0.95 * 2f64.powi(-6), "B: {worst_b}");
        // Denormals: absolute error at most half their step.
        for v in log_sweep(1e-9, 2f64.powi(-14), 20_001) {
            let back = decode_b10g11r11(encode_b10g11r11([v, v, v]));
            assert!((back[0] - v).abs() as f64 <= 2f64.powi(-21), "{v}: {back:?}");
            assert!((back[2] - v).abs() as f64 <= 2f64.powi(-20), "{v}: {back:?}");
        }
    }

    #[test]
    fn b10g11r11_known_words_and_clamps() {
        // 1.0 = exponent 15, mantissa 0 in each field.
        assert_eq!(encode_b10g11r11([1.0, 1.0, 1.0]), (15 << 6) | ((15 << 6) << 11) | ((15 << 5) << 22));
        assert_eq!(decode_b10g11r11(encode_b10g11r11([UF11_MAX, UF11_MAX, UF10_MAX])), [UF11_MAX, UF11_MAX, UF10_MAX]);
        // Beyond the range: clamped, never infinite or NaN; negatives and NaN -> 0.
        assert_eq!(decode_b10g11r11(encode_b10g11r11([1e9, f32::INFINITY, 1e30])), [UF11_MAX, UF11_MAX, UF10_MAX]);
        assert_eq!(decode_b10g11r11(encode_b10g11r11([-1.0, f32::NAN, -0.0])), [0.0, 0.0, 0.0]);
        // Ties go to even: 1 + 2^-7 is halfway between 1 and 1 + 2^-6 (R), and 1 + 3 2^-7 rounds up.
        assert_eq!(
            decode_b10g11r11(encode_b10g11r11([1.0 + 2f32.powi(-7), 1.0 + 3.0 * 2f32.powi(-7), 0.0]))[..2],
            [1.0, 1.0 + 2.0 * 2f32.powi(-6)]
        );
        // The smallest denormal and the carry from the largest denormal into the smallest normal.
        assert_eq!(decode_b10g11r11(encode_b10g11r11([2f32.powi(-20), 0.0, 0.0]))[0], 2f32.powi(-20));
        assert_eq!(
            decode_b10g11r11(encode_b10g11r11([2f32.powi(-14) * (1.0 - 2f32.powi(-8)), 0.0, 0.0]))[0],
            2f32.powi(-14)
        );
    }

    /// Max error relative to the largest channel over a log-uniform sweep of the largest channel,
    /// with the other two channels at fixed fractions of it (the shared exponent's weak spot).
    #[test]
    fn rgb9e5_rounding_error_is_within_2_to_the_minus_9_of_the_largest_channel() {
        let bound = 2f64.powi(-9) * 512.0 / 511.5;
        let mut worst = 0f64;
        for v in log_sweep(2f64.powi(-15), RGB9E5_MAX as f64, 200_001) {
            for rgb in [[v, v, v], [v, 0.37 * v, 0.0021 * v], [0.5 * v, v, 0.999 * v]] {
                let back = decode_rgb9e5(encode_rgb9e5(rgb));
                let max_c = v as f64;
                for k in 0..3 {
                    worst = worst.max((back[k] as f64 - rgb[k] as f64).abs() / max_c);
                }
            }
        }
        assert!(worst <= bound && worst > 0.95 * 2f64.powi(-9), "{worst} vs {bound}");
        // Below 2^-15 (the smallest exponent): absolute error at most 2^-25.
        for v in log_sweep(1e-12, 2f64.powi(-15), 20_001) {
            let back = decode_rgb9e5(encode_rgb9e5([v, 0.5 * v, 0.0]));
            assert!((back[0] - v).abs() as f64 <= 2f64.powi(-25) && (back[1] - 0.5 * v).abs() as f64 <= 2f64.powi(-25));
        }
    }

    #[test]
    fn rgb9e5_known_words_and_clamps() {
        // 1.0: exponent field 16 (2^(16 - 24) x 256), mantissa 256.
        assert_eq!(encode_rgb9e5([1.0, 0.0, 0.0]), 256 | (16 << 27));
        assert_eq!(decode_rgb9e5(encode_rgb9e5([1.0, 0.5, 0.25])), [1.0, 0.5, 0.25]);
        assert_eq!(decode_rgb9e5(encode_rgb9e5([RGB9E5_MAX; 3])), [RGB9E5_MAX; 3]);
        // A carry: 511.75/512 rounds to 512/512, so the exponent goes up by one.
        let word = encode_rgb9e5([511.75 / 512.0, 0.0, 0.0]);
        assert_eq!((word >> 27, word & 0x1ff), (16, 256));
        // Clamped: above the maximum, infinities, negatives, NaN.
        assert_eq!(decode_rgb9e5(encode_rgb9e5([1e9, f32::INFINITY, -5.0])), [RGB9E5_MAX, RGB9E5_MAX, 0.0]);
        assert_eq!(decode_rgb9e5(encode_rgb9e5([f32::NAN, f32::NAN, f32::NAN])), [0.0; 3]);
        assert_eq!(encode_rgb9e5([0.0; 3]), 0);
    }
}
