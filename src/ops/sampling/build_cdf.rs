//! `BuildCdf(luminance, sin_theta: true, sanitize: false)`: the 2D piecewise-constant
//! distribution of a lat-long luminance map (see `values::distribution` for the maths and for what
//! zero rows, black maps, NaN/Inf/negative texels and 1xN maps do).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::ops::latlong_input::warn_unless_latlong;
use crate::values::ty::*;
use crate::values::Distribution2D;
use crate::values::Image;

crate::params! {
    pub struct BuildCdfParams {
        /// the lat-long luminance (Luminance of the map)
        #[input(&[SCALAR_T])]
        pub luminance: Input<Image>,
        /// weight texels by sin(theta), their solid angle; false reproduces the seed's comparison
        pub sin_theta: bool = true,
        /// treat NaN and negative texels as 0 and +Inf as the largest float instead of failing
        pub sanitize: bool = false,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "BuildCdf",
        1,
        "Importance-sampling distribution of a lat-long map: marginal over rows, conditional per row (f64)",
        eval,
    )
    .output("cdf", DISTRIBUTION_T, "the distribution")
    .size(|_, p| p.luminance.size)
    .into()
}

fn eval(ctx: &mut OpContext, p: BuildCdfParams) -> Result<Value, OpError> {
    warn_unless_latlong(ctx, &p.luminance);
    let dist =
        Distribution2D::build(&p.luminance, p.sin_theta, p.sanitize).map_err(|e| OpError::Invalid(e.to_string()))?;
    Ok(Value::new(dist))
}
