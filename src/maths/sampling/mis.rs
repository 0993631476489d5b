//! Multiple importance sampling: the weighting heuristics (Veach 1997, section 9.2.2), shared by
//! the glossy sphere (`maths::render::glossy`) and the per-pixel diffuse sphere (`maths::render::per_pixel`).

crate::choice! {
    /// The MIS weighting heuristic (Veach 1997, section 9.2.2).
    pub enum Heuristic {
        /// `w_i = n_i p_i / sum_k n_k p_k`.
        Balance,
        /// `w_i = (n_i p_i)^2 / sum_k (n_k p_k)^2` (exponent beta = 2, Veach's recommendation).
        Power,
    }
}

impl Heuristic {
    /// The weight of a technique of (count x density) `a` against the other's `b`; 0 when both
    /// are 0.
    #[inline]
    pub fn weight(self, a: f64, b: f64) -> f64 {
        let (a, b) = match self {
            Heuristic::Balance => (a, b),
            Heuristic::Power => (a * a, b * b),
        };
        let sum = a + b;
        if sum > 0.0 && sum.is_finite() {
            a / sum
        } else if a.is_infinite() {
            1.0
        } else {
            0.0
        }
    }
}
