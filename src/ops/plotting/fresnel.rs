//! `Fresnel(eta_i, eta_t, steps: 901)`: exact dielectric reflectance for s and p polarisation
//! and their mean from 0 to 90 degrees, with the Brewster angle atan(eta_t/eta_i) and, when
//! eta_i > eta_t, the critical angle asin(eta_t/eta_i) in closed form (see `maths::brdf::fresnel`).

use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::brdf::fresnel::fresnel_curves;
use crate::values::ty::*;

crate::params! {
    pub struct FresnelParams {
        /// refractive index of the incident medium
        #[range(1e-6, 1e6)]
        pub eta_i: f64 = 1.0,
        /// refractive index of the transmitting medium
        #[range(1e-6, 1e6)]
        pub eta_t: f64 = 1.5,
        /// number of angles from 0 to 90 degrees inclusive
        #[range(2, 1_000_000)]
        pub steps: usize = 901,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "Fresnel",
        1,
        "Dielectric Fresnel reflectance curves (Rs, Rp, R) with exact Brewster and critical angles",
        eval,
    )
    .output("curves", CURVES_T, "Rs, Rp and R against the angle of incidence")
    .into()
}

fn eval(_: &mut OpContext, p: FresnelParams) -> Result<Value, OpError> {
    Ok(Value::new(fresnel_curves(p.eta_i, p.eta_t, p.steps)))
}
