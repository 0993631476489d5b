//! `IrradianceCubemap(env, size, method: Sh, order: 2, window: None)`: the diffuse irradiance
//! cube map, `E(n) / pi = (1/pi) int L(l) (n.l)+ dl` (a constant environment of radiance 1 gives 1:
//! the radiance a white Lambertian surface reflects), at every texel of a cube of face `size`.
//!
//! - `method: Exact`: the sum over every source texel, the reference.
//! - `method: Sh`: spherical harmonics up to band `order` (Ramamoorthi and Hanrahan 2001), band l
//!   scaled by a window `w_l`: `None`, `Hann`, `Lanczos` (Sloan 2008), or `Deringing`: the
//!   Laplacian window `1 / (1 + lambda l^2 (l+1)^2)` with the smallest `lambda` that makes the
//!   irradiance non-negative in every channel (Sloan, "Deringing Spherical Harmonics", 2017),
//!   found by bisection. Formulas and sources in `maths::ibl::irradiance_cube`.
//!
//! The `metrics` port reports `window_strength` (lambda for Deringing, 1 for Hann and Lanczos, 0
//! otherwise), `min_unwindowed` and `min_irradiance` (the smallest channel value over the output
//! texels and 6 x 32 x 32 more directions, without and with the window; for Exact both are the
//! output's minimum). White furnace to 1e-3 both ways (tests). `env` is a lat-long image (its own
//! texels are summed or projected) or a cube map; `source_size` reads it as a cube of that face
//! size instead (`ops::ibl::env_cube`: a cube 2^k times larger is halved k times, exactly), so
//! that a bake's irradiance can come from its specular source cube.

use crate::engine::fields::{AnyValue, Input};
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::ibl::irradiance_cube::{
    exact, from_sh, project_cube, project_latlong, IrradianceMethod, ShWindow, Texels,
};
use crate::values::ty::*;
use crate::values::{Cubemap, Metrics};

crate::params! {
    pub struct IrradianceCubemapParams {
        /// the environment: a lat-long RGB map or a cube map
        #[input(&[IMAGE_T, CUBEMAP_T])]
        pub env: Input<AnyValue>,
        /// face size of the output
        #[range(1, 1024)]
        pub size: usize = 32,
        /// Exact (sum over every source texel) or Sh
        pub method: IrradianceMethod = IrradianceMethod::Sh,
        /// highest SH band l (method: Sh)
        #[range(0, 32)]
        pub order: usize = 2,
        /// SH window: None, Hann, Lanczos, Deringing (smallest strength giving non-negative irradiance)
        pub window: ShWindow = ShWindow::None,
        /// read env as a cube map of this face size (a cube 2^k times larger is halved k times): Exact costs the output's texels times the source's
        #[range(1, 1024)]
        pub source_size: Option<usize>,
    }
}

/// The output ports, declared once: the spec and `eval` name them through these.
const CUBEMAP: Port<Cubemap> = Port::new("cubemap");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    Op::new(
        "IrradianceCubemap",
        2,
        "Diffuse irradiance / pi as a cube map, exactly or by windowed SH (Deringing: Sloan 2017); constant 1 gives 1",
        eval,
    )
    .port(CUBEMAP, CUBEMAP_T, "the irradiance / pi cube map")
    .port(METRICS, METRICS_T, "window_strength, min_unwindowed, min_irradiance")
    .size(|_, p| Some((6 * p.size as u64, p.size as u64)))
    .into()
}

fn eval(ctx: &mut OpContext, p: IrradianceCubemapParams) -> Result<Outputs, OpError> {
    let resized = match p.source_size {
        Some(s) => Some(super::env_cube(ctx, &p.env, s)?),
        None => None,
    };
    let (texels, coeffs) = if let Some(c) = resized.as_ref().or_else(|| p.env.value().get::<Cubemap>()) {
        super::check_cube_finite(c)?;
        let coeffs = (p.method == IrradianceMethod::Sh).then(|| project_cube(c, p.order));
        (Texels::from_cube(c), coeffs)
    } else {
        let img = super::env_image(ctx, &p.env)?;
        crate::ops::latlong_input::check_finite(img)?;
        let coeffs = (p.method == IrradianceMethod::Sh).then(|| project_latlong(img, p.order));
        (Texels::from_latlong(img), coeffs)
    };
    let (cube, metrics) = match coeffs {
        Some(coeffs) => {
            let (cube, r) = from_sh(&coeffs, p.order, p.window, p.size);
            let m = vec![
                ("window_strength".to_string(), r.strength),
                ("min_unwindowed".to_string(), r.min_unwindowed),
                ("min_irradiance".to_string(), r.min_windowed),
            ];
            (cube, m)
        }
        None => {
            let cube = exact(&texels, p.size);
            let min = cube.data.iter().fold(f64::INFINITY, |m, &v| m.min(v as f64));
            let m = vec![
                ("window_strength".to_string(), 0.0),
                ("min_unwindowed".to_string(), min),
                ("min_irradiance".to_string(), min),
            ];
            (cube, m)
        }
    };
    Ok(Outputs::new().port(CUBEMAP, cube).port(METRICS, Metrics { fields: metrics }))
}
