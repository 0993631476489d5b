//! The mean of a cut cell (`super`'s module docs): the source texels' shares of the cell's unit
//! square by inclusion-exclusion of clips a grid point of their boundaries.

use std::f64::consts::{PI, TAU};

use crate::maths::resample::polygon::{Clipped, Line, Poly};

/// A cut's polygons: the square clipped twice (a row's and a column's boundary).
type Poly6 = Poly<6>;
const SQUARE: Poly6 = Poly6::SQUARE;
use super::{Cells, Plan, MAX_TEXELS};
use crate::maths::resample::layouts::Footprint;

impl<F: Footprint> Cells<'_, '_, F> {
    /// The cut cell's mean value: each texel weighted by its share of the cell's solid angle, the
    /// density `1 + beta . (u, v)`. Texel (row, col)'s share is
    /// `C(row, col) - C(row - 1, col) - C(row, col - 1) + C(row - 1, col - 1)`, `C(i, j)` the
    /// weight of the square's part in rows up to i and columns up to j: a clip a grid point (none
    /// where the line misses the part), the whole square's weight 1. Once a row's part is the
    /// whole square, every later row's is too and their shares are 0: the rows stop there; once a
    /// column's clip keeps a row's whole part, so do the later columns' (no clip).
    pub(super) fn cut_mean(&self, plan: &Plan, beta: [f64; 2]) -> [f64; 3] {
        // A short table for the usual few columns: the long one's zeroing (1 KiB) showed in
        // profiles.
        if plan.cols.1 - plan.cols.0 < 8 {
            self.cut_mean_in::<9>(plan, beta)
        } else {
            self.cut_mean_in::<{ MAX_TEXELS + 1 }>(plan, beta)
        }
    }

    /// `cut_mean` with a table of `N` columns (more than the plan's).
    fn cut_mean_in<const N: usize>(&self, plan: &Plan, beta: [f64; 2]) -> [f64; 3] {
        let (t, f) = (plan.t, plan.f);
        let ((row0, row1), (col0, col1)) = (plan.rows, plan.cols);
        let (dt, df) = (PI / self.h as f64, TAU / self.w as f64);
        // C(row - 1, col) and C(row, col) a column, in turns (0 above the first row, and left of
        // the first column).
        let mut c = [[0.0f64; N]; 2];
        let mut mean = [0.0; 3];
        let (mut part, mut piece) = (SQUARE, SQUARE);
        for row in row0..=row1 {
            let (prev, cur) = if (row - row0) % 2 == 0 { (0, 1) } else { (1, 0) };
            // The square's part with theta below `(row + 1) dt`, and its weight.
            let whole = row == row1
                || match SQUARE.cut(Line { a: (row + 1) as f64 * dt - t.a, b: -t.b, c: -t.c }, &mut part) {
                    Clipped::All => true,
                    Clipped::Nothing => continue,
                    Clipped::Part => false,
                };
            let (part, total) = if whole { (&SQUARE, 1.0) } else { (&part, part.weight(beta)) };
            let mut kept = false;
            for (j, col) in (col0..=col1).enumerate() {
                // Its part with phi below `(col + 1) df`.
                c[cur][j + 1] = if kept || col == col1 || total == 0.0 {
                    total
                } else {
                    let edge = (col + 1) as f64 * df - plan.phi0;
                    match part.cut(Line { a: edge - f.a, b: -f.b, c: -f.c }, &mut piece) {
                        Clipped::All => {
                            kept = true;
                            total
                        }
                        Clipped::Nothing => 0.0,
                        Clipped::Part => piece.weight(beta),
                    }
                };
                let share = c[cur][j + 1] - c[prev][j + 1] - c[cur][j] + c[prev][j];
                if share != 0.0 {
                    let v = self.value_at(col, row);
                    for k in 0..3 {
                        mean[k] += share * v[k];
                    }
                }
            }
            if whole {
                break;
            }
        }
        mean
    }
}
