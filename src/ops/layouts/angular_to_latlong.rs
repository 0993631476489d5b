//! `AngularToLatLong(image, width: 1024, height: 512)`: Debevec angular light probe to lat-long.
//!
//! Angular map (Debevec, "Light Probe Image Gallery"): for image coordinates u, v in [-1, 1]
//! (u right, v up), r = sqrt(u^2 + v^2) <= 1 and the direction makes the angle pi*r with
//! forward; its azimuth around forward is atan2(v, u). The image centre looks forward, which in
//! hdrflow's lat-long convention is -Z (the centre column), with +X to the right and +Y up, so
//! a direction d maps to (u, v) = (d.x, d.y) * acos(-d.z) / (pi * sqrt(d.x^2 + d.y^2))
//! (`geometry::azimuthal::DiscMap::ANGULAR`). Pixels outside the unit disc carry no light
//! (grace_probe.hdr has copyright text there) and are masked out. Each output texel is a
//! bilinear lookup at its centre direction, taps outside the disc having weight 0
//! (`maths::resample::disc_image::disc_to_latlong`). `LatLongToAngular` is the inverse.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::azimuthal::DiscMap;
use crate::maths::resample::disc_image::disc_to_latlong;
use crate::values::ty::*;
use crate::values::Image;

crate::params! {
    pub struct AngularParams {
        /// the angular probe (square)
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// output width
        #[range(1, 1 << 28)]
        pub width: usize = 1024,
        /// output height
        #[range(1, 1 << 28)]
        pub height: usize = 512,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "AngularToLatLong",
        1,
        "Convert a Debevec angular light probe to a lat-long map (outside the disc masked)",
        eval,
    )
    .output_like("image", |p| p.image, "the lat-long map")
    .size(|_, p| Some((p.width as u64, p.height as u64)))
    .into()
}

/// Converts an angular probe to a `width` x `height` lat-long map (channel names kept).
pub fn angular_to_latlong(probe: &Image, width: usize, height: usize) -> Image {
    disc_to_latlong(probe, &DiscMap::ANGULAR, 1.0, width, height).image
}

fn eval(_: &mut OpContext, p: AngularParams) -> Result<Value, OpError> {
    Ok(Value::new(angular_to_latlong(&p.image, p.width, p.height)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outside_the_disc_is_masked() {
        // A probe that is 1 inside the disc and 1000 outside: no 1000 may leak.
        let n = 64;
        let mut probe = Image::new(n, n, 1);
        for y in 0..n {
            for x in 0..n {
                let u = 2.0 * (x as f64 + 0.5) / n as f64 - 1.0;
                let v = 1.0 - 2.0 * (y as f64 + 0.5) / n as f64;
                probe.data[y * n + x] = if u * u + v * v <= 1.0 { 1.0 } else { 1000.0 };
            }
        }
        let ll = angular_to_latlong(&probe, 64, 32);
        assert!(ll.data.iter().all(|&v| v <= 1.0 + 1e-6), "outside-disc pixels leaked");
        assert!(ll.data.iter().filter(|&&v| v == 1.0).count() > 64 * 32 * 9 / 10);
    }
}
