//! `HierarchicalWarp`: a [`Distribution2D`]'s texels drawn by descending a mip-map of their
//! probabilities, as Mitsuba 3's `Hierarchical2D` warp does (its envmap emitter's sampler; the
//! method is Clarberg et al., "Wavelet importance sampling", SIGGRAPH 2005, section 4, and
//! McCool and Harwood, "Probability trees", 1997).
//!
//! Level 0 holds every texel's probability `P(x, y)` ([`Distribution2D::texel_probability`]),
//! padded with zeros to power-of-two sides; each coarser level sums 2x2 blocks (2x1 once one side
//! is 1) until one value is left. A draw starts at the top with `(ux, uy)` and at each level
//! chooses the block's row with `uy` (in proportion to the two rows' sums) and then the column in
//! that row with `ux`, rescaling the chosen uniform to the chosen part, `u <- (u - c0) / c1`; at
//! level 0 the rescaled `(ux, uy)` are where the point fell inside the texel.
//!
//! The texel probabilities are the same as inversion's ([`crate::maths::sampling::guide_table`]): the product of
//! the ratios along the path telescopes to `P(x, y) / total`. Only the map from the unit square
//! to the texels differs: inversion sends a horizontal band of `u1` to a band of rows and `u2`
//! to columns row by row, whereas the descent sends each quadrant of the unit square to a
//! spatially compact part of the map (a quadtree node). A low-discrepancy 2D point set, whose
//! every elementary box of area `1/N` holds one point, therefore stays evenly spread over the
//! map's area at every scale, which is what a smooth integrand (a cosine lobe times the map)
//! rewards. With independent uniforms both warps give the same estimator distribution, so
//! per-pixel sampling uses this one with Sobol points only (docs/src/benchmarks/relighting.md has the errors).
//!
//! Values are f32 (as Mitsuba's): half the memory traffic of f64. Each level's sum rounds once,
//! so the probability the descent gives a texel differs from `P(x, y)` by a relative
//! `(levels + 1) * 2^-24` at most (about 7e-7 on a 1024x512 map; a test checks it), which is
//! the bias of an estimator that divides by the exact `P`. Blocks are stored contiguously (the
//! four values a step reads share one 16-byte slot), so a step costs one memory read.
//!
//! Speed: a batch descends level by level, so its reads of one level are in flight together,
//! each step prefetching the next level's block; a step chooses without branches (the choice is
//! a coin flip a branch predictor would miss half the time) and rescales both uniforms with one
//! division; at the AVX-512 level (`crate::cpu`) the 2x2 steps run eight draws at once (gathers of the
//! four values), with the same bits as the scalar step (a test). Each of these steps was timed
//! against CDF inversion (docs/src/benchmarks/relighting.md, "Per-pixel sampling against Mitsuba 3", `warp:
//! Hierarchical`); the descent stays slower per sample than inversion.

use rayon::prelude::*;

use crate::cpu;
use crate::maths::prefetch;
use crate::values::distribution::clamp_unit;
use crate::values::Distribution2D;

/// One level: `width x height` values (powers of two), stored block by block, each block
/// `block_w x block_h` (2x2, or 2x1 / 1x2 once a side is 1) in row-major order inside.
struct Level {
    width: usize,
    height: usize,
    /// `width / block_w`, kept so that a step does no integer division.
    blocks_per_row: usize,
    values: Vec<f32>,
}

impl Level {
    fn new(width: usize, height: usize) -> Level {
        Level { width, height, blocks_per_row: width / width.min(2), values: vec![0.0; width * height] }
    }

    #[inline(always)]
    fn block_dims(&self) -> (usize, usize) {
        (self.width.min(2), self.height.min(2))
    }

    /// Sets every value `(x, y)` to `value(x, y)`, rows of blocks in parallel.
    fn fill(&mut self, value: impl Fn(usize, usize) -> f32 + Sync) {
        let (bw, bh) = self.block_dims();
        let row_len = self.blocks_per_row * bw * bh;
        let width = self.width;
        self.values.par_chunks_mut(row_len).enumerate().for_each(|(by, chunk)| {
            for dy in 0..bh {
                for x in 0..width {
                    chunk[(x / bw) * (bw * bh) + dy * bw + x % bw] = value(x, by * bh + dy);
                }
            }
        });
    }

    /// Where block `(bx, by)` (the children of node `(bx, by)` one level up) starts.
    #[inline(always)]
    fn block_start(&self, bx: usize, by: usize) -> usize {
        let (bw, bh) = self.block_dims();
        (by * self.blocks_per_row + bx) * (bw * bh)
    }

    /// Where value `(x, y)` is stored.
    #[inline(always)]
    fn index(&self, x: usize, y: usize) -> usize {
        let (bw, bh) = self.block_dims();
        self.block_start(x / bw, y / bh) + (y % bh) * bw + x % bw
    }
}

/// The probability pyramid of a distribution (see the module documentation). About
/// `4/3 * 4 * W' H'` bytes for power-of-two sides `W' >= W`, `H' >= H`.
pub struct HierarchicalWarp {
    /// `levels[0]` is the finest (texel) level; the last has one block (the top's children).
    levels: Vec<Level>,
    /// The map's size (level 0 may be padded beyond it).
    width: usize,
    height: usize,
}

/// A draw between [`HierarchicalWarp::start`] and [`HierarchicalWarp::finish`]: the node
/// reached so far (at the level above the next step) and the rescaled uniforms.
#[derive(Clone, Copy, Debug, Default)]
pub struct WarpDraw {
    x: usize,
    y: usize,
    ux: f64,
    uy: f64,
}

/// Chooses between two parts of masses `c0` and `c1` with `u` in [0, 1): whether the second
/// was chosen, and the offset and width of the chosen part in `s = u (c0 + c1)`, from which
/// `u` rescaled to that part is `(s - offset) / width`. A part of zero mass is never chosen (the
/// parent's mass is positive when the descent reaches it, so one of the two is positive).
/// Without branches: the choice is a coin flip the processor could not predict.
#[inline(always)]
fn choose(u: f64, c0: f64, c1: f64) -> (bool, f64, f64) {
    let s = u * (c0 + c1);
    let second = ((s >= c0) & (c1 > 0.0)) | (c0 <= 0.0);
    // Selected by multiplying with 0 or 1 (exact: one term is 0, the other unchanged). Written
    // as `if` or as bit masks, the compiler emits a branch, which the processor mispredicts
    // half the time.
    let (on, off) = (second as u8 as f64, (!second) as u8 as f64);
    let offset = c0 * on;
    let width = c1 * on + c0 * off;
    (second, s - offset, width)
}

/// `numerator / width` as a uniform in [0, 1) (0.5 for an empty part, which only rounding can
/// reach).
#[inline(always)]
fn rescale(numerator: f64, width: f64) -> f64 {
    if width > 0.0 {
        clamp_unit(numerator / width)
    } else {
        0.5
    }
}

impl HierarchicalWarp {
    /// Builds the pyramid from `dist`'s texel probabilities (level 0's rows in parallel).
    pub fn new(dist: &Distribution2D) -> HierarchicalWarp {
        let (w, h) = (dist.width(), dist.height());
        let (pw, ph) = (w.max(1).next_power_of_two(), h.max(1).next_power_of_two());
        let mut finest = Level::new(pw, ph);
        // `texel_probability` is 0 outside the map, i.e. in the padding up to powers of two.
        finest.fill(|x, y| dist.texel_probability(x, y) as f32);
        let mut levels = vec![finest];
        // Sum blocks until the last level is one block (the top's children).
        loop {
            let fine = levels.last().expect("level 0 is there");
            let (bw, bh) = fine.block_dims();
            let (cw, ch) = (fine.width / bw, fine.height / bh);
            if cw * ch == 1 {
                break;
            }
            let mut coarse = Level::new(cw, ch);
            // Value (cx, cy) is the sum of the fine level's block (cx, cy), its bw*bh
            // consecutive values.
            coarse.fill(|cx, cy| {
                let block = fine.block_start(cx, cy);
                fine.values[block..block + bw * bh].iter().map(|&v| v as f64).sum::<f64>() as f32
            });
            levels.push(coarse);
        }
        HierarchicalWarp { levels, width: w, height: h }
    }

    /// Number of levels (for the bias bound of the module documentation).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Starts a draw at the top of the pyramid with `u1` choosing rows and `u2` columns (the
    /// roles they have in inversion), clamped to [0, 1).
    #[inline(always)]
    pub fn start(&self, u1: f64, u2: f64) -> WarpDraw {
        // `+ 0.0` turns -0.0 into +0.0, which the AVX-512 clamp would do (its `max` returns the
        // second operand for equal zeros), so both paths see the same bits.
        WarpDraw { x: 0, y: 0, ux: clamp_unit(u2) + 0.0, uy: clamp_unit(u1) + 0.0 }
    }

    /// One step down: from a node of level `level + 1` (or the top) to its child at `level`,
    /// then a prefetch of that child's block one level further down.
    #[inline(always)]
    fn step(&self, level: usize, draw: &mut WarpDraw) {
        let l = &self.levels[level];
        let (bw, bh) = l.block_dims();
        let base = l.block_start(draw.x, draw.y);
        let v = |i: usize| l.values[base + i] as f64;
        let (mut x, mut y) = (draw.x * bw, draw.y * bh);
        if bh == 2 && bw == 2 {
            // The row with `uy`, then the column in that row with `ux`; the two rescalings
            // share one division, `1 / (wy wx)` (a division costs several multiplications).
            let (r0, r1) = (v(0) + v(1), v(2) + v(3));
            let (down, ny, wy) = choose(draw.uy, r0, r1);
            let row = 2 * down as usize;
            let (right, nx, wx) = choose(draw.ux, v(row), v(row + 1));
            if wy > 0.0 && wx > 0.0 {
                let inv = 1.0 / (wy * wx);
                draw.uy = clamp_unit(ny * wx * inv);
                draw.ux = clamp_unit(nx * wy * inv);
            } else {
                draw.uy = rescale(ny, wy);
                draw.ux = rescale(nx, wx);
            }
            y += down as usize;
            x += right as usize;
        } else if bh == 2 {
            let (down, ny, wy) = choose(draw.uy, v(0), v(1));
            draw.uy = rescale(ny, wy);
            y += down as usize;
        } else if bw == 2 {
            let (right, nx, wx) = choose(draw.ux, v(0), v(1));
            draw.ux = rescale(nx, wx);
            x += right as usize;
        }
        draw.x = x;
        draw.y = y;
        if level > 0 {
            let below = &self.levels[level - 1];
            prefetch(&below.values[below.block_start(x, y)]);
        }
    }

    /// Descends every draw of a batch level by level, so the batch's reads of one level are in
    /// flight together (each step prefetches the next level's block). The draws must come
    /// fresh from [`Self::start`] (at the top: node (0, 0)); panics otherwise, since a draw
    /// descended twice would index past the top levels. At [`cpu::level`].
    #[inline]
    pub fn descend(&self, draws: &mut [WarpDraw]) {
        self.descend_at(cpu::level(), draws)
    }

    /// [`Self::descend`] at `level`: eight draws at a time at [`cpu::Level::Avx512`] (if the
    /// processor has it, [`cpu::usable`]), the scalar steps below; the same bits either way.
    #[inline]
    pub fn descend_at(&self, level: cpu::Level, draws: &mut [WarpDraw]) {
        assert!(draws.iter().all(|d| d.x == 0 && d.y == 0), "descend takes draws fresh from start");
        #[cfg(target_arch = "x86_64")]
        if draws.len() >= 8 && cpu::usable(level) == cpu::Level::Avx512 {
            for group in draws.chunks_mut(x86::GROUP) {
                // SAFETY: the CPU has AVX-512F and DQ (`cpu::usable` above), and every draw starts at
                // node (0, 0) (asserted above), so each level's gathers read the block of a node
                // the level above chose: inside that level's values.
                unsafe { x86::descend_group(self, group) };
            }
            return;
        }
        for level in (0..self.levels.len()).rev() {
            for draw in draws.iter_mut() {
                self.step(level, draw);
            }
        }
    }

    /// The texel a descended draw reached and where it fell inside: `(x, y, rx, ry)`, with
    /// `(rx, ry)` uniform on [0, 1)^2 given the texel (each step's rescaling is the inversion
    /// of a two-point distribution). The texel is inside the map (padding has zero mass; a
    /// map that carries no light is uniform, so its padding is never reached either).
    #[inline(always)]
    pub fn finish(&self, draw: &WarpDraw) -> (usize, usize, f64, f64) {
        (draw.x.min(self.width.saturating_sub(1)), draw.y.min(self.height.saturating_sub(1)), draw.ux, draw.uy)
    }

    /// One draw, all stages: `(x, y, rx, ry)` (see [`Self::finish`]).
    pub fn sample(&self, u1: f64, u2: f64) -> (usize, usize, f64, f64) {
        let mut draw = [self.start(u1, u2)];
        self.descend(&mut draw);
        self.finish(&draw[0])
    }

    /// The probability that a draw reaches texel `(x, y)`: the product of the ratios of the
    /// masses along its path (what the descent's choices give, including the f32 roundings).
    pub fn texel_probability(&self, x: usize, y: usize) -> f64 {
        let mut p = 1.0;
        let (mut cx, mut cy) = (x, y);
        for l in &self.levels {
            let (bw, bh) = l.block_dims();
            let (bx, by) = (cx / bw, cy / bh);
            let base = l.block_start(bx, by);
            let total: f64 = l.values[base..base + bw * bh].iter().map(|&v| v as f64).sum();
            let own = l.values[l.index(cx, cy)] as f64;
            if total <= 0.0 {
                return 0.0;
            }
            p *= own / total;
            cx = bx;
            cy = by;
        }
        p
    }
}

/// The 2x2 step of [`HierarchicalWarp::step`] for 8 draws at once with AVX-512 (one lane per
/// draw): the same operations in the same order, so the same bits as the scalar step (a test
/// compares them). The scalar step runs at the levels below and for a batch's tail.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{HierarchicalWarp, Level, WarpDraw};
    use crate::maths::prefetch;
    use crate::values::distribution::ONE_MINUS_EPSILON;

    /// `clamp_unit` per lane: `max(x, 0)` returns its second operand, 0, for NaN.
    #[inline(always)]
    unsafe fn clamp_unit(x: __m512d) -> __m512d {
        _mm512_min_pd(_mm512_max_pd(x, _mm512_setzero_pd()), _mm512_set1_pd(ONE_MINUS_EPSILON))
    }

    /// `choose` per lane: the mask of lanes that took the second part, the numerator and the
    /// width (the scalar `choose`'s multiplications by 0 and 1 are exact, so blends give the
    /// same values).
    #[inline(always)]
    unsafe fn choose(u: __m512d, c0: __m512d, c1: __m512d) -> (__mmask8, __m512d, __m512d) {
        let zero = _mm512_setzero_pd();
        let s = _mm512_mul_pd(u, _mm512_add_pd(c0, c1));
        let second = (_mm512_cmp_pd_mask::<_CMP_GE_OQ>(s, c0) & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(c1, zero))
            | _mm512_cmp_pd_mask::<_CMP_LE_OQ>(c0, zero);
        let offset = _mm512_mask_blend_pd(second, zero, c0);
        let width = _mm512_mask_blend_pd(second, c0, c1);
        (second, _mm512_sub_pd(s, offset), width)
    }

    /// `rescale` per lane.
    #[inline(always)]
    unsafe fn rescale(n: __m512d, width: __m512d) -> __m512d {
        let positive = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(width, _mm512_setzero_pd());
        _mm512_mask_blend_pd(positive, _mm512_set1_pd(0.5), clamp_unit(_mm512_div_pd(n, width)))
    }

    /// Draws per group: the group's lanes are kept as arrays (one per field) across the levels.
    pub(super) const GROUP: usize = 16;

    /// [`HierarchicalWarp::descend`] for up to [`GROUP`] draws: level by level, eight lanes at a
    /// time on the 2x2 levels, the scalar step elsewhere and for a tail of fewer than 8.
    #[target_feature(enable = "avx512f,avx512dq")]
    pub(super) unsafe fn descend_group(warp: &HierarchicalWarp, draws: &mut [WarpDraw]) {
        let n = draws.len();
        assert!(n <= GROUP);
        let (mut xs, mut ys, mut uxs, mut uys) = ([0i64; GROUP], [0i64; GROUP], [0f64; GROUP], [0f64; GROUP]);
        for (i, d) in draws.iter().enumerate() {
            (xs[i], ys[i], uxs[i], uys[i]) = (d.x as i64, d.y as i64, d.ux, d.uy);
        }
        let wide = n / 8 * 8;
        for level in (0..warp.levels.len()).rev() {
            let l = &warp.levels[level];
            let below = level.checked_sub(1).map(|b| &warp.levels[b]);
            let first_scalar = if l.block_dims() == (2, 2) {
                for c in (0..wide).step_by(8) {
                    let r = c..c + 8;
                    step8_2x2(l, below, &mut xs[r.clone()], &mut ys[r.clone()], &mut uxs[r.clone()], &mut uys[r]);
                }
                wide
            } else {
                0
            };
            for i in first_scalar..n {
                let mut d = WarpDraw { x: xs[i] as usize, y: ys[i] as usize, ux: uxs[i], uy: uys[i] };
                warp.step(level, &mut d);
                (xs[i], ys[i], uxs[i], uys[i]) = (d.x as i64, d.y as i64, d.ux, d.uy);
            }
        }
        for (i, d) in draws.iter_mut().enumerate() {
            (d.x, d.y, d.ux, d.uy) = (xs[i] as usize, ys[i] as usize, uxs[i], uys[i]);
        }
    }

    /// One 2x2 level for eight lanes (slices of 8), then a prefetch of each lane's next block.
    #[target_feature(enable = "avx512f,avx512dq")]
    unsafe fn step8_2x2(
        level: &Level,
        below: Option<&Level>,
        xs: &mut [i64],
        ys: &mut [i64],
        uxs: &mut [f64],
        uys: &mut [f64],
    ) {
        assert!(xs.len() == 8 && ys.len() == 8 && uxs.len() == 8 && uys.len() == 8);
        let x = _mm512_loadu_epi64(xs.as_ptr());
        let y = _mm512_loadu_epi64(ys.as_ptr());
        let (ux, uy) = (_mm512_loadu_pd(uxs.as_ptr()), _mm512_loadu_pd(uys.as_ptr()));
        // Block start (y * blocks_per_row + x) * 4, then its four values.
        let base = _mm512_slli_epi64::<2>(_mm512_add_epi64(
            _mm512_mullo_epi64(y, _mm512_set1_epi64(level.blocks_per_row as i64)),
            x,
        ));
        let values = level.values.as_ptr();
        let gather = |k: i64| {
            let index = _mm512_add_epi64(base, _mm512_set1_epi64(k));
            _mm512_cvtps_pd(_mm512_i64gather_ps::<4>(index, values))
        };
        let (v0, v1, v2, v3) = (gather(0), gather(1), gather(2), gather(3));
        let (r0, r1) = (_mm512_add_pd(v0, v1), _mm512_add_pd(v2, v3));
        let (down, ny, wy) = choose(uy, r0, r1);
        let (c0, c1) = (_mm512_mask_blend_pd(down, v0, v2), _mm512_mask_blend_pd(down, v1, v3));
        let (right, nx, wx) = choose(ux, c0, c1);
        let zero = _mm512_setzero_pd();
        let both = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(wy, zero) & _mm512_cmp_pd_mask::<_CMP_GT_OQ>(wx, zero);
        let inv = _mm512_div_pd(_mm512_set1_pd(1.0), _mm512_mul_pd(wy, wx));
        let shared_uy = clamp_unit(_mm512_mul_pd(_mm512_mul_pd(ny, wx), inv));
        let shared_ux = clamp_unit(_mm512_mul_pd(_mm512_mul_pd(nx, wy), inv));
        let uy = _mm512_mask_blend_pd(both, rescale(ny, wy), shared_uy);
        let ux = _mm512_mask_blend_pd(both, rescale(nx, wx), shared_ux);
        let one = _mm512_set1_epi64(1);
        let (y2, x2) = (_mm512_add_epi64(y, y), _mm512_add_epi64(x, x));
        let y = _mm512_mask_add_epi64(y2, down, y2, one);
        let x = _mm512_mask_add_epi64(x2, right, x2, one);
        _mm512_storeu_epi64(xs.as_mut_ptr(), x);
        _mm512_storeu_epi64(ys.as_mut_ptr(), y);
        _mm512_storeu_pd(uxs.as_mut_ptr(), ux);
        _mm512_storeu_pd(uys.as_mut_ptr(), uy);
        if let Some(below) = below {
            for i in 0..8 {
                prefetch(&below.values[below.block_start(xs[i] as usize, ys[i] as usize)]);
            }
        }
    }
}

#[cfg(test)]
mod tests;
