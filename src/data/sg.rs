//! `SphericalGaussians`: an environment approximated as a sum of spherical Gaussian lobes, as
//! `SphericalGaussians` fits them (the compact lighting model of Wang et al., "All-frequency
//! rendering of dynamic, spatially-varying reflectance", SIGGRAPH Asia 2009, and of the
//! lighting-estimation papers that followed).

use std::f64::consts::PI;

use glam::DVec3;

/// One lobe, `L(d) = amplitude exp(sharpness (axis . d - 1))`: its peak `amplitude` (RGB, the
/// map's units) is at `axis`, and it falls to `1/e` at the angle `acos(1 - 1/sharpness)`
/// (about `1 / sqrt(sharpness)` radians for a sharp lobe).
#[derive(Clone, Debug, PartialEq)]
pub struct SgLobe {
    /// Unit direction of the peak (hdrflow's world axes: +Y up, see `geometry::latlong`).
    pub axis: [f64; 3],
    /// `lambda > 0`: the larger, the narrower.
    pub sharpness: f64,
    /// The peak radiance per channel (RGB).
    pub amplitude: [f64; 3],
}

impl SgLobe {
    /// `exp(lambda (axis . d - 1))`, in (0, 1] for a unit `d`.
    #[inline]
    pub fn kernel(&self, d: [f64; 3]) -> f64 {
        (self.sharpness * (DVec3::from(self.axis).dot(DVec3::from(d)) - 1.0)).exp()
    }

    /// `L(d)` per channel.
    pub fn value(&self, d: [f64; 3]) -> [f64; 3] {
        let g = self.kernel(d);
        self.amplitude.map(|a| a * g)
    }

    /// The lobe's integral over the sphere per channel, in closed form:
    /// `int exp(lambda (cos t - 1)) dw = 2 pi int_{-1}^{1} exp(lambda (u - 1)) du
    /// = 2 pi (1 - exp(-2 lambda)) / lambda` (written with `expm1`, exact to rounding for any
    /// lambda; 4 pi in the limit lambda -> 0).
    pub fn integral(&self) -> [f64; 3] {
        let l = self.sharpness;
        let solid = if l > 0.0 { 2.0 * PI * -(-2.0 * l).exp_m1() / l } else { 4.0 * PI };
        self.amplitude.map(|a| a * solid)
    }
}

/// A sum of lobes: `L(d) = sum_k L_k(d)`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SphericalGaussians {
    /// The lobes, most energetic first when `SphericalGaussians` fitted them.
    pub lobes: Vec<SgLobe>,
}

impl SphericalGaussians {
    /// `L(d)` per channel.
    pub fn value(&self, d: [f64; 3]) -> [f64; 3] {
        value_of(&self.lobes, d)
    }

    /// The integral over the sphere per channel (the sum of the lobes' closed forms).
    pub fn integral(&self) -> [f64; 3] {
        sum_of(self.lobes.iter().map(SgLobe::integral))
    }
}

/// `L(d) = sum_k L_k(d)` per channel, the lobes added in order.
pub fn value_of(lobes: &[SgLobe], d: [f64; 3]) -> [f64; 3] {
    sum_of(lobes.iter().map(|l| l.value(d)))
}

/// The per-channel sum of RGB triples, in order.
fn sum_of(items: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
    items.fold([0.0; 3], |s, v| [s[0] + v[0], s[1] + v[1], s[2] + v[2]])
}
