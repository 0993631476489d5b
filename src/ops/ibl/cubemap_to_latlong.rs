//! `CubemapToLatLong(cubemap, width, height)`: a cube map as a W x H lat-long RGB map (hdrflow's
//! lat-long convention), each texel the solid-angle-weighted average of the cube map (read as
//! piecewise constant) over its footprint `dphi (cos theta0 - cos theta1)` (`maths::resample::layouts`):
//! energy-preserving, exact for a constant map, 1e-3 relative on the built-in sky (tests).

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::resample::layouts::{to_latlong, CubeSource};
use crate::values::ty::*;
use crate::values::Cubemap;

super::latlong_size_params!(CubemapToLatLongParams {
    /// the cube map
    #[input(&[CUBEMAP_T])]
    pub cubemap: Input<Cubemap>,
});

pub fn spec() -> OpSpec {
    Op::new(
        "CubemapToLatLong",
        1,
        "Cube map to lat-long map, each texel the solid-angle-weighted mean of its footprint",
        eval,
    )
    .output("image", IMAGE_T, "the lat-long RGB map")
    .size(|_, p| Some((p.width as u64, p.height as u64)))
    .into()
}

fn eval(_: &mut OpContext, p: CubemapToLatLongParams) -> Result<Value, OpError> {
    let c = &*p.cubemap;
    super::check_cube_finite(c)?;
    Ok(Value::new(to_latlong(&CubeSource::new(c), p.width, p.height)))
}
