//! The split-sum LUTs: GGX's DFG texture ([`brdf_lut`]) and glTF-IBL-Sampler's Charlie sheen LUT
//! ([`charlie_lut`]), each texel as `ggx::dfg` and `charlie::charlie_lut_texel` define it, made one
//! row at a time. A row is one
//! roughness, so its half vectors do not depend on the column: they are drawn once per row and
//! kept as two arrays (`h.x`, `h.z`: with `v = (sqrt(1 - n.v^2), 0, n.v)` the `y` component never
//! enters), with every factor that depends on the sample alone (Charlie's `D`). Each texel is
//! then a sum over the samples of a few products, one square root and one division (GGX) or a
//! reciprocal (Charlie), in lanes of 8 that the compiler vectorises, compiled for AVX-512 and AVX2
//! and dispatched through `crate::cpu` (the same bits at every level, test). The per-texel
//! formulas are those of `ggx::dfg` and `charlie::charlie_lut_texel`, which stay the scalar
//! references: the rows agree with them to the output's f32 rounding (summation order apart;
//! tested at 1e-6 relative).
//!
//! Why by hand: the texel functions draw each half vector again for every texel (two square roots
//! and a sine and cosine per sample), which made a 4096 x 4096 LUT of 1024 samples, the size
//! glTF-IBL-Sampler gives a 16k map's Khronos bake, take most of an hour.

use rayon::prelude::*;

use crate::cpu::Level;
use crate::maths::brdf::charlie::v_ashikhmin;
use crate::maths::brdf::ggx::{points, sample_h, LobeSequence};
use crate::maths::brdf::specular_lobe::SpecularBrdf;
use crate::values::Image;

/// The size x size DFG texture: column x is `n.v = (x + 0.5) / size`, row y (row 0 at the top) is
/// perceptual roughness `(y + 0.5) / size`; channels `R`, `G` = (scale, bias), or (`E[Fc Gv]`,
/// `E[Gv]`) with `multiscatter`.
pub fn brdf_lut(size: usize, samples: usize, seq: LobeSequence, multiscatter: bool) -> Image {
    let pts = points(seq, samples);
    let mut data = vec![0.0f32; size * size * 2];
    // Row by row, each texel as `dfg` computes it .
    data.par_chunks_mut(2 * size).enumerate().for_each(|(y, row)| {
        dfg_row((y as f64 + 0.5) / size as f64, &pts, multiscatter, row);
    });
    Image::with_names(size, size, vec!["R".into(), "G".into()], data)
}

/// The size x size Charlie LUT: column x is `n.v = (x + 0.5) / size`, row y (row 0 at the top) is
/// the sheen roughness `(y + 0.5) / size`; channels `R`, `G`, `B` = (0, 0, LUT), as
/// glTF-IBL-Sampler writes it and the viewer reads `.b`; `samples` Hammersley points.
pub fn charlie_lut(size: usize, samples: usize) -> Image {
    let pts = points(LobeSequence::Hammersley, samples);
    let mut data = vec![0.0f32; size * size * 3];
    // Row by row, each texel as `charlie::charlie_lut_texel` computes it.
    data.par_chunks_mut(3 * size).enumerate().for_each(|(y, row)| {
        charlie_row((y as f64 + 0.5) / size as f64, &pts, row);
    });
    Image::with_names(size, size, vec!["R".into(), "G".into(), "B".into()], data)
}

/// The lanes of one accumulation step.
const LANES: usize = 8;

/// A row's samples: half vector components, and per sample the factor that does not depend on
/// the view (Charlie's `D`; unused for GGX).
struct RowSamples {
    hx: Vec<f64>,
    hz: Vec<f64>,
    d: Vec<f64>,
}

impl RowSamples {
    /// Padded to a multiple of [`LANES`] with samples that never count (`h.z = 0`).
    fn pad(mut self) -> RowSamples {
        while !self.hx.len().is_multiple_of(LANES) {
            self.hx.push(0.0);
            self.hz.push(0.0);
            self.d.push(0.0);
        }
        self
    }
}

/// The GGX half vectors of a row: `ggx::sample_h` at alpha = roughness^2.
fn ggx_samples(roughness: f64, pts: &[[f64; 2]]) -> RowSamples {
    let alpha = roughness * roughness;
    let h: Vec<_> = pts.iter().map(|&u| sample_h(u, alpha)).collect();
    RowSamples { hx: h.iter().map(|h| h.x).collect(), hz: h.iter().map(|h| h.z).collect(), d: vec![0.0; h.len()] }.pad()
}

/// The Charlie half vectors of a row, drawn as glTF-IBL-Sampler's `Charlie(xi, roughness)` draws
/// them (alpha = roughness^2, the second point coordinate first), with `D_Charlie(roughness, n.h)`.
fn charlie_samples(roughness: f64, pts: &[[f64; 2]]) -> RowSamples {
    let h: Vec<_> =
        pts.iter().map(|xi| SpecularBrdf::Charlie.sample_h([xi[1], xi[0]], roughness * roughness)).collect();
    let d = h.iter().map(|h| SpecularBrdf::Charlie.d(h.z.clamp(0.0, 1.0), roughness)).collect();
    RowSamples { hx: h.iter().map(|h| h.x).collect(), hz: h.iter().map(|h| h.z).collect(), d }.pad()
}

/// One row of the DFG texture ([`brdf_lut`]): `out` holds (R, G) per column, n.v = (x + 0.5) /
/// width, from `pts` (unpadded count `n`); at [`crate::cpu::level`].
pub fn dfg_row(roughness: f64, pts: &[[f64; 2]], multiscatter: bool, out: &mut [f32]) {
    dfg_row_at(crate::cpu::level(), roughness, pts, multiscatter, out)
}

/// [`dfg_row`] at `level`.
fn dfg_row_at(level: Level, roughness: f64, pts: &[[f64; 2]], multiscatter: bool, out: &mut [f32]) {
    let s = ggx_samples(roughness, pts);
    let a2 = roughness.powi(4);
    let width = out.len() / 2;
    let n = pts.len().max(1) as f64;
    for x in 0..width {
        let nov = (x as f64 + 0.5) / width as f64;
        let [a, b] = dfg_sums(level, &s, nov, a2, multiscatter);
        out[2 * x] = (a / n) as f32;
        out[2 * x + 1] = (b / n) as f32;
    }
}

/// One row of the Charlie LUT ([`charlie_lut`]): `out` holds (R, G, B) = (0, 0, LUT) per
/// column; at [`crate::cpu::level`].
pub fn charlie_row(roughness: f64, pts: &[[f64; 2]], out: &mut [f32]) {
    charlie_row_at(crate::cpu::level(), roughness, pts, out)
}

/// [`charlie_row`] at `level`.
fn charlie_row_at(level: Level, roughness: f64, pts: &[[f64; 2]], out: &mut [f32]) {
    let s = charlie_samples(roughness, pts);
    let width = out.len() / 3;
    let scale = 8.0 * std::f64::consts::PI / pts.len().max(1) as f64;
    for x in 0..width {
        let nov = (x as f64 + 0.5) / width as f64;
        let c = charlie_sum(level, &s, nov);
        out[3 * x + 2] = (scale * c) as f32;
    }
}

crate::cpu::dispatch! {
    #[levels(Avx512, Avx2)]
    /// [`dfg_texel`], compiled for AVX-512, for AVX2 and FMA, and for the baseline.
    #[inline]
    fn dfg_sums(s: &RowSamples, nov: f64, a2: f64, multiscatter: bool) -> [f64; 2] = dfg_texel;
}

crate::cpu::dispatch! {
    #[levels(Avx512, Avx2)]
    /// [`charlie_texel`], compiled for AVX-512, for AVX2 and FMA, and for the baseline.
    #[inline]
    fn charlie_sum(s: &RowSamples, nov: f64) -> f64 = charlie_texel;
}

/// `ggx::dfg`'s sums (not yet divided by the sample count) at `n.v`, `a2` = alpha^2.
#[inline(always)]
fn dfg_texel(s: &RowSamples, nov: f64, a2: f64, multiscatter: bool) -> [f64; 2] {
    let sv = (1.0 - nov * nov).max(0.0).sqrt();
    // Smith height-correlated V = 0.5 / (n.l sqrt(n.v^2 (1 - a2) + a2) + n.v sqrt(n.l^2 (1 - a2) + a2)).
    let view_term = (nov * nov * (1.0 - a2) + a2).sqrt();
    let (mut x, mut y) = ([0.0f64; LANES], [0.0f64; LANES]);
    for (hx, hz) in s.hx.chunks_exact(LANES).zip(s.hz.chunks_exact(LANES)) {
        for i in 0..LANES {
            let voh = sv * hx[i] + nov * hz[i];
            let nol = 2.0 * voh * hz[i] - nov;
            let denom = nol * view_term + nov * (nol * nol * (1.0 - a2) + a2).sqrt();
            let gv = 2.0 * nol * voh / (denom * hz[i]);
            let valid = nol > 0.0 && voh > 0.0 && hz[i] > 0.0 && denom > 0.0;
            let gv = if valid { gv } else { 0.0 };
            let fc = (1.0 - voh).powi(5);
            if multiscatter {
                x[i] += gv * fc;
                y[i] += gv;
            } else {
                x[i] += gv * (1.0 - fc);
                y[i] += gv * fc;
            }
        }
    }
    [x.iter().sum(), y.iter().sum()]
}

/// `charlie::charlie_lut_texel`'s sum (not yet scaled) at `n.v`.
#[inline(always)]
fn charlie_texel(s: &RowSamples, nov: f64) -> f64 {
    let sv = (1.0 - nov * nov).max(0.0).sqrt();
    let mut c = [0.0f64; LANES];
    for ((hx, hz), d) in s.hx.chunks_exact(LANES).zip(s.hz.chunks_exact(LANES)).zip(s.d.chunks_exact(LANES)) {
        for i in 0..LANES {
            let voh = sv * hx[i] + nov * hz[i];
            let nol = (2.0 * voh * hz[i] - nov).clamp(0.0, 1.0);
            let term = d[i] * v_ashikhmin(nol, nov) * nol * voh.clamp(0.0, 1.0);
            c[i] += if nol > 0.0 { term } else { 0.0 };
        }
    }
    c.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::brdf::charlie::charlie_lut_texel;
    use crate::maths::brdf::ggx::dfg;

    /// Scale + bias (or the multiscatter form's `E[Gv]`) never exceed 1 and are never negative.
    #[test]
    fn the_dfg_table_is_bounded() {
        for multi in [false, true] {
            let lut = brdf_lut(16, 512, LobeSequence::Sobol, multi);
            for px in lut.data.chunks(2) {
                let total = if multi { px[1] } else { px[0] + px[1] };
                assert!(total <= 1.0 + 1e-6 && px[0] >= 0.0 && px[1] >= 0.0, "{px:?}");
            }
        }
    }

    /// Every texel of a few rows (roughness 0 to 1, the smallest and grazing n.v included) against
    /// the scalar texel functions, for a sample count that is not a multiple of the lanes.
    #[test]
    fn rows_match_the_scalar_texels() {
        let width = 37;
        for samples in [1000, 64] {
            let hammersley = points(LobeSequence::Hammersley, samples);
            for rough in [0.0005, 0.01, 0.2, 0.5, 0.77, 1.0] {
                for multiscatter in [false, true] {
                    let mut row = vec![0.0f32; 2 * width];
                    dfg_row(rough, &hammersley, multiscatter, &mut row);
                    for x in 0..width {
                        let nov = (x as f64 + 0.5) / width as f64;
                        let want = dfg(nov, rough, &hammersley, multiscatter);
                        for k in 0..2 {
                            let got = row[2 * x + k] as f64;
                            assert!(
                                (got - want[k]).abs() <= 1e-6 * (1.0 + want[k].abs()),
                                "r {rough} n.v {nov}: {got} vs {}",
                                want[k]
                            );
                        }
                    }
                }
                let mut row = vec![0.0f32; 3 * width];
                charlie_row(rough, &hammersley, &mut row);
                for x in 0..width {
                    let nov = (x as f64 + 0.5) / width as f64;
                    let want = charlie_lut_texel(nov, rough, &hammersley);
                    let got = row[3 * x + 2] as f64;
                    assert!(
                        (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
                        "charlie r {rough} n.v {nov}: {got} vs {want}"
                    );
                    assert_eq!((row[3 * x], row[3 * x + 1]), (0.0, 0.0));
                }
            }
        }
    }

    /// Every level the processor has gives the portable rows' bits (the same loops, compiled for
    /// each).
    #[test]
    fn every_level_gives_the_portable_bits() {
        let levels = crate::cpu::tested_levels();
        let width = 37;
        let pts = points(LobeSequence::Sobol, 100);
        for rough in [0.0005, 0.2, 0.77, 1.0] {
            for multiscatter in [false, true] {
                let mut portable = vec![0.0f32; 2 * width];
                dfg_row_at(Level::Portable, rough, &pts, multiscatter, &mut portable);
                for &level in &levels {
                    let mut row = vec![0.0f32; 2 * width];
                    dfg_row_at(level, rough, &pts, multiscatter, &mut row);
                    let bits = |r: &[f32]| r.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&row), bits(&portable), "dfg {level} r {rough} {multiscatter}");
                }
            }
            let mut portable = vec![0.0f32; 3 * width];
            charlie_row_at(Level::Portable, rough, &pts, &mut portable);
            for &level in &levels {
                let mut row = vec![0.0f32; 3 * width];
                charlie_row_at(level, rough, &pts, &mut row);
                assert!(
                    row.iter().zip(&portable).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "charlie {level} r {rough}"
                );
            }
        }
    }

    /// The 128 x 128 table of 1024 samples (the khronos bake's default): R = G = 0, B finite, not
    /// negative, above 1 only in the grazing, low-roughness corner (n.v < 0.13, r < 0.36: what a
    /// 16-bit or 8-bit PNG clamps), never above 2.5.
    #[test]
    fn values_above_one_stay_in_the_grazing_low_roughness_corner() {
        let lut = charlie_lut(128, 1024);
        assert_eq!(lut.names, ["R", "G", "B"]);
        let mut over = 0;
        for (i, px) in lut.data.chunks_exact(3).enumerate() {
            let (x, y) = (i % 128, i / 128);
            assert_eq!((px[0], px[1]), (0.0, 0.0));
            assert!(px[2].is_finite() && px[2] >= 0.0 && px[2] < 2.5, "({x}, {y}): {}", px[2]);
            if px[2] > 1.0 {
                over += 1;
                assert!(x <= 16 && y <= 45, "({x}, {y}): {}", px[2]);
            }
        }
        assert!(over > 0 && over < 600, "{over} texels above 1");
    }
}
