//! Debevec and Malik's response recovery ("Recovering High Dynamic Range Radiance Maps from
//! Photographs", SIGGRAPH 1997, section 2.1 and appendix A), per channel.
//!
//! Unknowns: `g(z) = ln x(z)` for the 256 codes and `ln E_i` for each sample pixel `i`.
//! Equations, in the least-squares sense: for every sample `i` and frame `j` (code `z_ij`,
//! time `t_j`), `w(z_ij) (g(z_ij) - ln E_i) = w(z_ij) ln t_j`; `g(128) = 0`; and the
//! smoothness `lambda w(z) (g(z - 1) - 2 g(z) + g(z + 1)) = 0` for `z = 1..=254`. `w` is the
//! paper's hat, `w(z) = min(z, 255 - z)` (OpenCV's `CalibrateDebevec` uses `z + 1` and
//! `256 - z`, so that clipped codes still pull on `g`; the paper's gives them none). The
//! `(N P + 255) x (256 + N)` system is solved by Householder QR ([`least_squares`]), as exact
//! as OpenCV's SVD for a full-rank system and never forming the normal equations. Samples with
//! no weight in any frame (clipped or black everywhere) are left out: their `ln E` would be
//! free.
//!
//! The sample pixels are OpenCV's regular grid ([`sample_points`]). 16-bit codes are binned
//! to 256 (`z >> 8`): the system has one unknown per code, and 65536 of them would need
//! millions of samples; the 256 bin values are then interpolated at the 65536 codes
//! ([`expand`]). The result is made non-decreasing ([`Response::make_monotonic`]): codes no
//! sample saw are extrapolated by the smoothness term alone and may bend back.

use super::response::{mid_code, Response};
use crate::values::brackets::Brackets;

/// The sample pixels of `samples` requested over a `width x height` image, as OpenCV's
/// `CalibrateDebevec` (not random) picks them: `nx = floor(sqrt(samples width / height))`
/// columns and `ny = samples / nx` rows, steps `sx = width / nx` and `sy = height / ny`, at
/// `x = sx / 2 + i sx`. OpenCV starts the rows at `y = sy` (so its last row can fall outside
/// the image); here rows start at `sy / 2` like the columns. Each count is at least 1.
pub fn sample_points(width: usize, height: usize, samples: usize) -> Vec<(usize, usize)> {
    let nx = (((samples as f64) * width as f64 / height as f64).sqrt() as usize).clamp(1, width);
    let ny = (samples / nx).clamp(1, height);
    let (sx, sy) = (width / nx, height / ny);
    let mut out = Vec::with_capacity(nx * ny);
    for i in 0..nx {
        for j in 0..ny {
            out.push((sx / 2 + i * sx, sy / 2 + j * sy));
        }
    }
    out
}

/// The paper's hat weight over 256 codes.
fn hat(z: usize) -> f64 {
    z.min(255 - z) as f64
}

/// A frame's code at sample index `i`, binned to 8 bits.
fn code8(b: &Brackets, f: usize, i: usize) -> usize {
    (b.frames[f].codes.get(i) >> (b.bit_depth - 8)) as usize
}

/// The response of `b`'s camera by Debevec and Malik (see the module documentation).
pub fn debevec(b: &Brackets, lambda: f64, samples: usize) -> Result<Response, String> {
    let points = sample_points(b.width, b.height, samples);
    let p = b.frames.len();
    let mut g = [vec![], vec![], vec![]];
    for (c, gc) in g.iter_mut().enumerate() {
        // The samples with some weight in this channel.
        let used: Vec<usize> = points
            .iter()
            .map(|&(x, y)| (y * b.width + x) * 3 + c)
            .filter(|&i| (0..p).any(|f| hat(code8(b, f, i)) > 0.0))
            .collect();
        if used.len() < 2 {
            return Err(format!(
                "channel {} has {} usable samples of {}: every other sample is black or clipped in every frame",
                ["R", "G", "B"][c],
                used.len(),
                points.len()
            ));
        }
        let n = 256 + used.len();
        let m = used.len() * p + 1 + 254;
        let mut a = vec![0.0; m * n]; // column-major
        let mut rhs = vec![0.0; m];
        let mut row = 0;
        for (k, &i) in used.iter().enumerate() {
            for f in 0..p {
                let z = code8(b, f, i);
                let w = hat(z);
                a[z * m + row] = w;
                a[(256 + k) * m + row] = -w;
                rhs[row] = w * b.frames[f].time.ln();
                row += 1;
            }
        }
        a[128 * m + row] = 1.0;
        row += 1;
        for z in 1..255 {
            let w = lambda * hat(z);
            a[(z - 1) * m + row] = w;
            a[z * m + row] = -2.0 * w;
            a[(z + 1) * m + row] = w;
            row += 1;
        }
        let sol = least_squares(&mut a, m, n, &mut rhs).ok_or_else(|| {
            format!("channel {}: the Debevec system is singular (too few distinct codes)", ["R", "G", "B"][c])
        })?;
        *gc = sol[..256].iter().map(|v| v.exp()).collect();
    }
    Ok(expand(g, b.bit_depth))
}

/// A response over all codes of `bits` from the relative exposures of 256 bins (bin `k` holds
/// the codes `k 2^(bits-8) ..`): at 8 bits the bins are the codes; at 16 bits each code's value
/// is interpolated linearly between the bins' centres (constant beyond the first and last).
/// Normalised so the middle code is 1, and made non-decreasing.
pub fn expand(bins: [Vec<f64>; 3], bits: u8) -> Response {
    let x = if bits == 8 {
        bins
    } else {
        let step = (1usize << (bits - 8)) as f64;
        bins.map(|v| {
            (0..1usize << bits)
                .map(|z| {
                    let u = ((z as f64 + 0.5) / step - 0.5).clamp(0.0, 255.0);
                    let k = (u as usize).min(254);
                    let f = u - k as f64;
                    v[k] * (1.0 - f) + v[k + 1] * f
                })
                .collect()
        })
    };
    let mid = mid_code(bits);
    let x = x.map(|v| {
        let norm = v[mid];
        v.into_iter().map(|e| e / norm).collect()
    });
    let mut r = Response { bits, x };
    r.make_monotonic();
    r
}

/// `argmin ||A s - b||` for a full-rank `m x n` `A` (column-major, `m >= n`) by Householder QR
/// (Golub and Van Loan, algorithm 5.3.2, then back substitution); `A` and `b` are overwritten.
/// `None` when a column is numerically dependent on the previous ones (a pivot below `1e-10`
/// times the largest column norm).
pub fn least_squares(a: &mut [f64], m: usize, n: usize, b: &mut [f64]) -> Option<Vec<f64>> {
    let col_norm =
        |a: &[f64], j: usize, from: usize| a[j * m + from..(j + 1) * m].iter().map(|v| v * v).sum::<f64>().sqrt();
    let scale = (0..n).map(|j| col_norm(a, j, 0)).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) || m < n {
        return None;
    }
    let mut diag = vec![0.0; n];
    for k in 0..n {
        let norm = col_norm(a, k, k);
        if !(norm > 1e-10 * scale) {
            return None;
        }
        let alpha = if a[k * m + k] > 0.0 { -norm } else { norm };
        a[k * m + k] -= alpha;
        let (head, tail) = a.split_at_mut((k + 1) * m);
        let v = &head[k * m + k..(k + 1) * m];
        let vv: f64 = v.iter().map(|x| x * x).sum();
        for j in 0..n - k - 1 {
            let col = &mut tail[j * m + k..(j + 1) * m];
            let f = 2.0 * v.iter().zip(col.iter()).map(|(x, y)| x * y).sum::<f64>() / vv;
            col.iter_mut().zip(v).for_each(|(y, x)| *y -= f * x);
        }
        let f = 2.0 * v.iter().zip(&b[k..]).map(|(x, y)| x * y).sum::<f64>() / vv;
        b[k..].iter_mut().zip(v).for_each(|(y, x)| *y -= f * x);
        diag[k] = alpha;
    }
    let mut s = vec![0.0; n];
    for k in (0..n).rev() {
        let mut acc = b[k];
        for j in k + 1..n {
            acc -= a[j * m + k] * s[j];
        }
        s[k] = acc / diag[k];
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_matches_the_normal_equations() {
        // A 5 x 3 overdetermined system with a known least-squares solution.
        let rows = [[1.0, 0.0, 2.0], [0.5, 1.0, 0.0], [0.0, 3.0, 1.0], [1.0, 1.0, 1.0], [2.0, -1.0, 0.5]];
        let b0 = [1.0, 2.0, 0.5, -1.0, 3.0];
        let (m, n) = (5, 3);
        let mut a: Vec<f64> = (0..n).flat_map(|j| rows.iter().map(move |r| r[j])).collect();
        let mut b = b0.to_vec();
        let s = least_squares(&mut a, m, n, &mut b).unwrap();
        // The residual is orthogonal to every column.
        for j in 0..n {
            let dot: f64 = (0..m).map(|i| rows[i][j] * (b0[i] - (0..n).map(|k| rows[i][k] * s[k]).sum::<f64>())).sum();
            assert!(dot.abs() < 1e-12, "{dot}");
        }
        let mut dependent = vec![1.0, 2.0, 3.0, 2.0, 4.0, 6.0];
        assert!(least_squares(&mut dependent, 3, 2, &mut [1.0, 1.0, 1.0]).is_none());
    }

    #[test]
    fn the_sample_grid_is_opencvs_and_stays_inside() {
        let pts = sample_points(300, 200, 70);
        // nx = floor(sqrt(70 * 1.5)) = 10, ny = 7, steps 30 and 28.
        assert_eq!(pts.len(), 70);
        assert_eq!(pts[0], (15, 14));
        assert_eq!(pts[69], (285, 14 + 6 * 28));
        for (w, h, s) in [(1, 1, 70), (3, 1000, 70), (1000, 2, 5000), (64, 32, 1)] {
            assert!(sample_points(w, h, s).iter().all(|&(x, y)| x < w && y < h), "{w}x{h}");
        }
    }
}
