//! Rec. 709 luminance, the one definition every operator that weighs light by brightness uses
//! (ITU-R BT.709 primaries, the same weights as `Luminance(weights: Rec709)`).

/// The Rec. 709 luminance weights of R, G, B.
pub const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// `Y = 0.2126 R + 0.7152 G + 0.0722 B`, summed in f64.
#[inline]
pub fn rec709_luminance(rgb: [f32; 3]) -> f64 {
    REC709[0] * rgb[0] as f64 + REC709[1] * rgb[1] as f64 + REC709[2] * rgb[2] as f64
}
