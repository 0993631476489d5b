//! What each pixel of the probe-lit sphere of tests/three_render.rs should be when three.js 0.187
//! renders it (`src/renderers/shaders/ShaderChunk/lights_physical_pars_fragment.glsl.js`,
//! `lights_fragment_begin.glsl.js`, `lights_fragment_end.glsl.js` of the pinned package).
//!
//! A `LightProbe` of coefficients `c_i` (`SphericalHarmonics3`) gives the irradiance
//! `E_SH(n) = sum_l A_l sum_m c_lm Y_lm(n)` at the world normal n (`shGetIrradianceAt` in
//! `lights_pars_begin.glsl.js`: `0.886227 = pi x 0.282095`, `2 x 0.511664 = (2 pi / 3) x
//! 0.488603`, `2 x 0.429043 = (pi / 4) x 1.092548`, ...: Ramamoorthi and Hanrahan's form with the
//! basis in slots 1-3 as y, z, x, which is `maths::ibl::sh::irradiance_sh` in hdrflow's `World`
//! frame). Then:
//!
//! - `MeshLambertMaterial`: `E_SH (albedo / pi)`, exactly.
//! - `MeshStandardMaterial` (metalness 0, roughness 1, colour white): the probe's light goes
//!   through `RE_IndirectDiffuse_Physical`, which keeps for the diffuse layer only what the
//!   specular lobe does not reflect: `E_SH / pi x (1 - FssEss - Fms Ems)`, with (A, B) =
//!   three's DFG table at (roughness, n.v), `FssEss = F0 A + F90 B`, `Ess = A + B`,
//!   `Ems = 1 - Ess`, `Favg = F0 + (1 - F0) / 21`, `Fms = FssEss Favg / (1 - Ems Favg)`
//!   (Fdez-Aguera, "A Multiple-Scattering Microfacet Model for Real-Time Image-based Lighting",
//!   JCGT 8(1), 2019), F0 = 0.04 and F90 = 1 for a standard dielectric. No environment map, so
//!   the specular terms read zero radiance. [`energy_left`] evaluates the factor with the exact
//!   DFG integral (`ggx::dfg`, 1024 Sobol points) where three reads a 16 x 16 half-float table:
//!   the white-furnace frame of the test (a probe of constant radiance 1) shows three's own.
//!
//! The reference is the map's exact irradiance (`maths::render::reference::irradiance_exact`, the sum
//! over its texels) in place of `E_SH`: the difference is the order-2 SH's approximation plus
//! three's arithmetic. `sh` is `E_SH` of the coefficients three was given, evaluated here, so
//! the frame against `sh` is three's arithmetic alone.

use std::f64::consts::PI;

use glam::DVec3;
use hdrflow::maths::brdf::ggx::{dfg, points, LobeSequence};
use hdrflow::maths::ibl::sh::irradiance_sh;
use hdrflow::maths::render::reference::irradiance_exact;
use hdrflow::values::{Image, ShFrame};

/// F0 of three's `MeshStandardMaterial` (no IOR: `material.specularColor = vec3(0.04)`).
pub const F0_STANDARD: f64 = 0.04;

/// The fraction of a white diffuse layer's light three keeps under a specular layer of `f0`
/// (F90 = 1) at perceptual roughness `roughness`, seen at `nov` (the module doc's formula, exact
/// DFG).
pub fn energy_left(nov: f64, roughness: f64, f0: f64) -> f64 {
    let [a, b] = dfg(nov.clamp(1e-4, 1.0), roughness, &points(LobeSequence::Sobol, 1024), false);
    let fss_ess = f0 * a + b;
    let ems = 1.0 - (a + b);
    let f_avg = f0 + (1.0 - f0) / 21.0;
    let fms = fss_ess * f_avg / (1.0 - ems * f_avg);
    1.0 - fss_ess - fms * ems
}

/// The references at `pixels` (index, unit normal; view +Z).
pub struct ProbeReference {
    pub pixels: Vec<usize>,
    /// the exact `E / pi`
    pub exact: Vec<[f64; 3]>,
    /// `E_SH / pi` of the coefficients three was given
    pub sh: Vec<[f64; 3]>,
    /// [`energy_left`] at each pixel (roughness 1, F0 0.04)
    pub energy: Vec<f64>,
}

impl ProbeReference {
    pub fn new(map: &Image, coefficients: &[[f64; 3]], pixels: &[(usize, DVec3)]) -> ProbeReference {
        let normals: Vec<[f64; 3]> = pixels.iter().map(|p| p.1.to_array()).collect();
        ProbeReference {
            pixels: pixels.iter().map(|p| p.0).collect(),
            exact: irradiance_exact(map, &normals).iter().map(|e| e.map(|c| c / PI)).collect(),
            sh: normals.iter().map(|&n| irradiance_sh(coefficients, 2, ShFrame::World, n).map(|c| c / PI)).collect(),
            energy: pixels.iter().map(|p| energy_left(p.1.z, 1.0, F0_STANDARD)).collect(),
        }
    }

    /// `values` times the energy factor: what a `MeshStandardMaterial` shows.
    pub fn standard(&self, values: &[[f64; 3]]) -> Vec<[f64; 3]> {
        values.iter().zip(&self.energy).map(|(v, w)| v.map(|c| c * w)).collect()
    }

    /// The energy factor as RGB: the white furnace's frame.
    pub fn furnace(&self) -> Vec<[f64; 3]> {
        self.energy.iter().map(|&w| [w; 3]).collect()
    }
}

#[test]
fn a_white_metal_keeps_no_diffuse_light_and_a_dielectric_keeps_most() {
    // F0 = F90 = 1: single and multiple scattering together reflect everything (three's
    // multiscattering model conserves energy in the furnace), nothing is left for the diffuse.
    for nov in [0.1, 0.5, 1.0] {
        let w = energy_left(nov, 0.6, 1.0);
        assert!(w.abs() < 1e-12, "{nov}: {w}");
    }
    // F0 = 0.04 at roughness 1: a few percent go to the specular lobe, more at grazing angles.
    let (head_on, grazing) = (energy_left(1.0, 1.0, F0_STANDARD), energy_left(0.1, 1.0, F0_STANDARD));
    assert!(head_on > 0.95 && head_on < 0.99 && grazing < head_on, "{head_on} {grazing}");
}
