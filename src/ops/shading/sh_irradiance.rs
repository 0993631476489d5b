//! `ShIrradiance(env, order: 2, frame: World)`: the real spherical-harmonic coefficients
//! `L_lm = sum_texels L Y_lm(d) dOmega` of the map up to band `order`, per channel, with the
//! basis evaluated in the axes `frame` names. With `order: 2` these are the 9 coefficients of
//! Ramamoorthi and Hanrahan's irradiance environment map (SIGGRAPH 2001). The basis (real SH,
//! orthonormal, no Condon-Shortley phase) and the frames are documented in `maths::ibl::sh`:
//!
//! - `World` (default): `(x, y, z)` = hdrflow's `(X, Y, Z)`, +Y up, -Z forward, as Y-up engines
//!   evaluate the basis with a world normal (three.js `SphericalHarmonics3`, Filament).
//! - `Paper`: `(x, y, z) = (X, Y, -Z)`, Ramamoorthi and Hanrahan's frame for a Debevec probe
//!   (z forward), in which their published Grace Cathedral table is reproduced.
//! - `LatLong`: `(x, y, z) = (Z, -X, Y)`, z up and azimuth = the map's phi: version 1's output,
//!   bit for bit.
//!
//! Three output ports: `coefficients` (default), an `sh coefficients` value that carries its order
//! and frame (saved as `.json` or `.csv`, printed as a table), `metrics`, the same numbers as
//! the flat record of version 1 (`L_{l}_{m}_{r|g|b}`, e.g. `L_0_0_r`, `L_1_-1_g`, in the order
//! l, m, channel), in the chosen frame, and `filament`, Filament's 9 pre-scaled irradiance
//! coefficients in the chosen frame (`E / pi = sh0 + sh1 y + sh2 z + sh3 x + ...`, cmgen's
//! `--sh-shader` form; bands past `order` are 0; `maths::ibl::sh_filament`), saved as cmgen's `sh.txt`
//! (`.txt`) or `.json`. Use `frame: World` for Filament's world.
//!
//! `yaw` gives the coefficients of the map turned about +Y as `Rotate(yaw)` would turn it, without
//! turning it (`maths::ibl::sh::project_turned`: a shift of the azimuth): the SH of rotation
//! augmentations, or of a map some other node has turned (the three.js preset reads its turned map
//! and turns it back).
//!
//! Version 2: the `frame` field (version 1 always used `LatLong`), the `sh coefficients` type on
//! the default port, and the `metrics` port.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::ibl::sh::{coefficient_name, project_turned, sh_lm};
use crate::maths::ibl::sh_filament::prescaled;
use crate::ops::latlong_input::{check_finite, warn_unless_latlong};
use crate::values::ty::*;
use crate::values::FilamentSh;
use crate::values::{Image, Metrics, ShCoefficients, ShFrame};

crate::params! {
    pub struct ShIrradianceParams {
        /// the lat-long environment (linear RGB)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// highest band l
        #[range(0, 32)]
        pub order: usize = 2,
        /// axes of the basis: World (X, Y up, Z: three.js, Filament), Paper (X, Y, -Z: Ramamoorthi-Hanrahan for a Debevec probe), LatLong (Z, -X, Y: version 1)
        pub frame: ShFrame = ShFrame::World,
        /// degrees about +Y: the coefficients of the map turned as Rotate(yaw) turns it, without turning it (exact for any angle)
        #[range(-3600.0, 3600.0)]
        pub yaw: f64 = 0.0,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const COEFFICIENTS: Port<ShCoefficients> = Port::new("coefficients");
const METRICS: Port<Metrics> = Port::new("metrics");
const FILAMENT: Port<FilamentSh> = Port::new("filament");

pub fn spec() -> OpSpec {
    Op::new(
        "ShIrradiance",
        2,
        "Spherical-harmonic coefficients L_lm of a lat-long map in a stated frame (order 2: Ramamoorthi-Hanrahan's 9)",
        eval,
    )
    .port(COEFFICIENTS, SH_COEFFICIENTS_T, "the coefficients, with their order and frame")
    .port(METRICS, METRICS_T, "the same numbers as flat fields L_l_m_channel (version 1's output)")
    .port(FILAMENT, FILAMENT_SH_T, "Filament's 9 pre-scaled irradiance coefficients (cmgen's sh.txt; Save as .txt)")
    .into()
}

fn eval(ctx: &mut OpContext, p: ShIrradianceParams) -> Result<Outputs, OpError> {
    warn_unless_latlong(ctx, &p.env);
    let env = &*p.env;
    check_finite(env)?;
    let rgb = project_turned(env, p.order, p.frame, p.yaw);
    let mut fields = Vec::with_capacity(rgb.len() * 3);
    for (i, c) in rgb.iter().enumerate() {
        let (l, m) = sh_lm(i);
        for (ch, &v) in c.iter().enumerate() {
            fields.push((coefficient_name(l, m, ch), v));
        }
    }
    let filament = FilamentSh { rgb: prescaled(&rgb) };
    Ok(Outputs::new()
        .port(COEFFICIENTS, ShCoefficients { order: p.order, frame: p.frame, rgb })
        .port(METRICS, Metrics { fields })
        .port(FILAMENT, filament))
}
