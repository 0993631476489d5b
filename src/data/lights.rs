//! `Lights`: a few parametric lights and an ambient colour, as `ExtractLights` takes them out
//! of an environment map (the parametric model of lighting-estimation papers).

use std::f64::consts::PI;

use crate::data::Light;

/// An environment approximated as a constant `ambient` radiance over the whole sphere plus
/// `lights`, each adding its `radiance` over its `solid_angle` around its `direction`. Its
/// integral is `sum_i radiance_i solid_angle_i + ambient 4 pi` per channel ([`Lights::power`]),
/// which `ExtractLights` makes equal to the map's.
#[derive(Clone, Debug, PartialEq)]
pub struct Lights {
    /// The lights, most energetic first.
    pub lights: Vec<Light>,
    /// The ambient radiance (RGB), over the whole sphere (4 pi sr).
    pub ambient: [f64; 3],
}

impl Lights {
    /// `sum_i radiance_i solid_angle_i + ambient 4 pi`, per channel: the model's integral over
    /// the sphere.
    pub fn power(&self) -> [f64; 3] {
        let mut p = self.ambient.map(|a| a * 4.0 * PI);
        for l in &self.lights {
            for (pc, lc) in p.iter_mut().zip(l.power()) {
                *pc += lc;
            }
        }
        p
    }
}
