//! The convex polygons of the cut cells (`maths::resample::cut_cells`): the cell's unit square
//! `[-1/2, 1/2]^2` clipped by the planes of the source's texel boundaries (Sutherland-Hodgman), and
//! a polygon's weight under a linear density, `integral of (1 + beta_u u + beta_v v) du dv`, from
//! its vertices (the shoelace formula for the area, and its first moments for the slopes).

/// A plane `a + b u + c v` over the cell's unit square.
#[derive(Clone, Copy)]
pub(super) struct Line {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) c: f64,
}

impl Line {
    #[inline]
    pub(super) fn at(&self, (u, v): (f64, f64)) -> f64 {
        self.a + self.b * u + self.c * v
    }
}

/// A convex polygon of at most 6 vertices (the square clipped twice), counter-clockwise in (u, v).
#[derive(Clone, Copy)]
pub(super) struct Poly {
    pub(super) n: usize,
    pub(super) p: [(f64, f64); 6],
}

/// Where a line leaves a polygon: wholly kept, wholly cut away, or cut (the kept part then
/// written out by [`Poly::cut`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Clipped {
    All,
    Nothing,
    Part,
}

pub(super) const SQUARE: Poly =
    Poly { n: 4, p: [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5), (0.0, 0.0), (0.0, 0.0)] };

impl Poly {
    /// The part where `line >= 0`, telling apart the cases where it is all or nothing (as
    /// [`Poly::clip`] would give them); only a `Part` is written to `out`. The line is evaluated
    /// once a vertex, and no polygon is copied where it is all or nothing.
    #[inline]
    pub(super) fn cut(&self, line: Line, out: &mut Poly) -> Clipped {
        if self.n == 0 {
            return Clipped::Nothing;
        }
        let mut f = [0.0; 6];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (v, &p) in f.iter_mut().zip(&self.p[..self.n]) {
            *v = line.at(p);
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        if lo >= 0.0 {
            Clipped::All
        } else if hi < 0.0 {
            Clipped::Nothing
        } else {
            self.clip_values(&f, out);
            Clipped::Part
        }
    }

    /// The part where `line >= 0` (the tests' shorthand for [`Poly::cut`]).
    #[cfg(test)]
    pub(super) fn clip(&self, line: Line) -> Poly {
        let mut out = Poly { n: 0, p: [(0.0, 0.0); 6] };
        let mut f = [0.0; 6];
        for (v, &p) in f.iter_mut().zip(&self.p[..self.n]) {
            *v = line.at(p);
        }
        self.clip_values(&f, &mut out);
        out
    }

    /// The part where the line, whose values at the vertices are `f`, is `>= 0`, into `out`.
    #[inline]
    fn clip_values(&self, f: &[f64; 6], out: &mut Poly) {
        out.n = 0;
        if self.n == 0 {
            return;
        }
        // Each edge a -> b adds its crossing, if any, then b if it is kept.
        let mut a = self.p[self.n - 1];
        let mut fa = f[self.n - 1];
        for (&b, &fb) in self.p[..self.n].iter().zip(f) {
            if (fa > 0.0 && fb < 0.0) || (fa < 0.0 && fb > 0.0) {
                let t = fa / (fa - fb);
                out.p[out.n] = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                out.n += 1;
            }
            if fb >= 0.0 {
                out.p[out.n] = b;
                out.n += 1;
            }
            (a, fa) = (b, fb);
        }
    }

    /// `integral over the polygon of (1 + beta_u u + beta_v v) du dv`.
    pub(super) fn weight(&self, [beta_u, beta_v]: [f64; 2]) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let (mut area, mut mu, mut mv) = (0.0, 0.0, 0.0);
        let mut a = self.p[self.n - 1];
        for &b in &self.p[..self.n] {
            let cross = a.0 * b.1 - b.0 * a.1;
            area += cross;
            mu += (a.0 + b.0) * cross;
            mv += (a.1 + b.1) * cross;
            a = b;
        }
        0.5 * area + (beta_u * mu + beta_v * mv) * (1.0 / 6.0)
    }
}
