//! `Light`: a distant light of small solid angle (a sun), as `SunExtract` takes it out of an
//! environment map.

/// A distant light: every direction within `solid_angle` steradians around `direction` carries
/// radiance `radiance` (RGB, the map's units). Its irradiance on a surface facing it is
/// `radiance * solid_angle` (for a small solid angle); `radiance * solid_angle` is also exactly
/// what `SunExtract` removed from the map's integral.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Unit direction towards the light (hdrflow's world axes: +Y up, see `geometry::latlong`).
    pub direction: [f64; 3],
    /// Solid angle in steradians (0 for "no light").
    pub solid_angle: f64,
    /// Radiance per channel (RGB); all 0 for "no light".
    pub radiance: [f64; 3],
}

impl Light {
    /// No light: zero radiance and solid angle, pointing at `direction`.
    pub fn none(direction: [f64; 3]) -> Light {
        Light { direction, solid_angle: 0.0, radiance: [0.0; 3] }
    }

    /// `radiance * solid_angle` per channel: the light's share of the map's integral.
    pub fn power(&self) -> [f64; 3] {
        self.radiance.map(|l| l * self.solid_angle)
    }
}
