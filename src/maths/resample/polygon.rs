//! Convex polygons in a cell's unit square `[-1/2, 1/2]^2`, clipped by planes `a + b u + c v >= 0`
//! (Sutherland-Hodgman), and their integrals from their vertices: a polygon's weight under a
//! linear density, `integral of (1 + beta_u u + beta_v v) du dv` (the shoelace formula for the
//! area, and its first moments for the slopes), and its moments in `u` up to the second. The cut
//! cells of a rotation (`maths::resample::cut_cells`, the source's texel boundaries across an
//! output cell) and the straddling texels of a cube map (`maths::resample::cell_clip`, a cube
//! texel's edges across a source texel) both integrate by them.

/// A plane `a + b u + c v` over the cell's unit square.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Line {
    pub(crate) a: f64,
    pub(crate) b: f64,
    pub(crate) c: f64,
}

impl Line {
    #[inline]
    pub(crate) fn at(&self, (u, v): (f64, f64)) -> f64 {
        self.a + self.b * u + self.c * v
    }
}

/// A convex polygon of at most `N` vertices, counter-clockwise in (u, v): the square clipped `k`
/// times has at most `4 + k` (a clip adds at most one vertex to a convex polygon).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Poly<const N: usize> {
    pub(crate) n: usize,
    pub(crate) p: [(f64, f64); N],
}

/// Where a line leaves a polygon: wholly kept, wholly cut away, or cut (the kept part then
/// written out by [`Poly::cut`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Clipped {
    All,
    Nothing,
    Part,
}

impl<const N: usize> Poly<N> {
    /// The unit square `[-1/2, 1/2]^2`.
    pub(crate) const SQUARE: Poly<N> = {
        let mut p = [(0.0, 0.0); N];
        p[0] = (-0.5, -0.5);
        p[1] = (0.5, -0.5);
        p[2] = (0.5, 0.5);
        p[3] = (-0.5, 0.5);
        Poly { n: 4, p }
    };

    /// The part where `line >= 0`, telling apart the cases where it is all or nothing (as
    /// [`Poly::clip`] would give them); only a `Part` is written to `out`. The line is evaluated
    /// once a vertex, and no polygon is copied where it is all or nothing.
    #[inline]
    pub(crate) fn cut(&self, line: Line, out: &mut Poly<N>) -> Clipped {
        if self.n == 0 {
            return Clipped::Nothing;
        }
        let mut f = [0.0; N];
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
    pub(crate) fn clip(&self, line: Line) -> Poly<N> {
        let mut out = Poly { n: 0, p: [(0.0, 0.0); N] };
        let mut f = [0.0; N];
        for (v, &p) in f.iter_mut().zip(&self.p[..self.n]) {
            *v = line.at(p);
        }
        self.clip_values(&f, &mut out);
        out
    }

    /// The part where the line, whose values at the vertices are `f`, is `>= 0`, into `out`.
    #[inline]
    fn clip_values(&self, f: &[f64; N], out: &mut Poly<N>) {
        out.n = 0;
        if self.n == 0 {
            return;
        }
        // Each edge a -> b adds its crossing, if any, then b if it is kept.
        let mut a = self.p[self.n - 1];
        let mut fa = f[self.n - 1];
        for (&b, &fb) in self.p[..self.n].iter().zip(f) {
            // A convex polygon gains at most one vertex; the checks keep a polygon that rounding
            // made very slightly reflex from overrunning the array (the extra vertex, within
            // rounding of its neighbours, is dropped).
            if ((fa > 0.0 && fb < 0.0) || (fa < 0.0 && fb > 0.0)) && out.n < N {
                let t = fa / (fa - fb);
                out.p[out.n] = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                out.n += 1;
            }
            if fb >= 0.0 && out.n < N {
                out.p[out.n] = b;
                out.n += 1;
            }
            (a, fa) = (b, fb);
        }
    }

    /// `integral over the polygon of (1 + beta_u u + beta_v v) du dv`.
    pub(crate) fn weight(&self, [beta_u, beta_v]: [f64; 2]) -> f64 {
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

    /// `[integral of 1, of u, of u^2]` over the polygon with `u` scaled by `su` and `v` by `sv`
    /// (the shoelace formula and its moments).
    pub(crate) fn moments_u(&self, su: f64, sv: f64) -> [f64; 3] {
        if self.n == 0 {
            return [0.0; 3];
        }
        let (mut area, mut mu, mut muu) = (0.0, 0.0, 0.0);
        let mut a = (self.p[self.n - 1].0 * su, self.p[self.n - 1].1 * sv);
        for &(u, v) in &self.p[..self.n] {
            let b = (u * su, v * sv);
            let cross = a.0 * b.1 - b.0 * a.1;
            area += cross;
            mu += (a.0 + b.0) * cross;
            muu += (a.0 * a.0 + a.0 * b.0 + b.0 * b.0) * cross;
            a = b;
        }
        [0.5 * area, mu / 6.0, muu / 12.0]
    }
}
