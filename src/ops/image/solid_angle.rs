//! `SolidAngle(width: 512, height: 256)`: the solid angle of every texel of a `width x height`
//! lat-long grid, in steradians, as a one-channel field (channel `Y`).
//!
//! Row `y` (row 0 at the zenith, texel centres at theta = pi (y + 0.5) / H) holds
//! `(2 pi / W)(pi / H) sin(theta)`: the midpoint rule, [`latlong::texel_solid_angle`], the
//! measure of every integral in hdrflow (multiply a map by it and sum to integrate over the
//! sphere). The exact band area is `(2 pi / W)(cos theta_top - cos theta_bottom)`; the grid sums
//! to `4 pi (x / sin x)` with `x = pi / 2H` (the sum of `sin((k + 1/2) pi / H)` over the rows is
//! `1 / sin(pi / 2H)`), i.e. `pi^2 / (24 H^2)` relative above 4 pi (2.5e-5 at H = 256). The
//! tests check that closed form to 1e-12 and each texel against `texel_solid_angle` (f32
//! rounding).

use rayon::prelude::*;

use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct SolidAngleParams {
        /// grid width in texels
        #[range(1, 1 << 28)]
        pub width: usize = 512,
        /// grid height in texels
        #[range(1, 1 << 28)]
        pub height: usize = 256,
    }
}

pub fn spec() -> OpSpec {
    Op::new("SolidAngle", 1, "The per-texel solid angle (sr) of a lat-long grid, one channel", eval)
        .output("solid_angle", SCALAR_T, "the solid angle of each texel")
        .size(|_, p| Some((p.width as u64, p.height as u64)))
        .persist(Persist::IfSmall)
        .into()
}

/// The solid-angle map of a `width x height` lat-long grid.
pub fn solid_angle_map(width: usize, height: usize) -> Image {
    let mut data = vec![0.0f32; width * height];
    if width > 0 {
        data.par_chunks_exact_mut(width).enumerate().for_each(|(y, row)| {
            row.fill(latlong::texel_solid_angle(y, width, height) as f32);
        });
    }
    Image::with_names(width, height, vec!["Y".into()], data)
}

fn eval(_: &mut OpContext, p: SolidAngleParams) -> Result<Value, OpError> {
    Ok(Value::new(solid_angle_map(p.width, p.height)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn sums_to_4pi_within_the_midpoint_rule_and_matches_texel_solid_angle() {
        for (w, h) in [(1, 1), (4, 2), (64, 32), (512, 256), (7, 1000)] {
            let m = solid_angle_map(w, h);
            for y in 0..h {
                let want = latlong::texel_solid_angle(y, w, h);
                for x in 0..w {
                    assert_eq!(m.pixel(x, y)[0], want as f32, "({x}, {y}) of {w}x{h}");
                }
            }
            // The f64 sum of the exact midpoint values: 4 pi x / sin x, x = pi / 2H.
            let exact: f64 = (0..h).map(|y| latlong::texel_solid_angle(y, w, h) * w as f64).sum();
            let x = PI / (2.0 * h as f64);
            assert!((exact / (4.0 * PI * x / x.sin()) - 1.0).abs() < 1e-12, "{w}x{h}: {exact}");
            // Above 4 pi, by pi^2 / (24 H^2) to leading order (within 2% of it from H = 32).
            let excess = exact / (4.0 * PI) - 1.0;
            let leading = PI * PI / (24.0 * (h * h) as f64);
            assert!(excess > 0.0, "{w}x{h}: {excess}");
            if h >= 32 {
                assert!((excess / leading - 1.0).abs() < 0.02, "{w}x{h}: {excess} vs {leading}");
            }
            // The stored f32 map sums to the same within f32 rounding.
            let stored: f64 = m.data.iter().map(|&v| v as f64).sum();
            assert!((stored / exact - 1.0).abs() < 1e-6, "{w}x{h}");
        }
    }
}
