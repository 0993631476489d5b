//! `AngularToLatLong(image, width: 1024, height: 512)`: Debevec angular light probe to lat-long.
//!
//! Angular map (Debevec, "Light Probe Image Gallery"): for image coordinates u, v in [-1, 1]
//! (u right, v up), r = sqrt(u^2 + v^2) <= 1 and the direction makes the angle pi*r with
//! forward; its azimuth around forward is atan2(v, u). The image centre looks forward, which in
//! hdrflow's lat-long convention is -Z (the centre column), with +X to the right and +Y up, so
//! a direction d maps to (u, v) = (d.x, d.y) * acos(-d.z) / (pi * sqrt(d.x^2 + d.y^2)).
//! Pixels outside the unit disc carry no light (grace_probe.hdr has copyright text there) and
//! are masked out. Each output texel is a bilinear lookup at its centre direction, taps outside
//! the disc having weight 0.

use rayon::prelude::*;

use crate::data::Image;
use crate::engine::fields::{Check, Input};
use crate::engine::op::{OpContext, OpError, OpSpec};
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::maths::bilinear;
use crate::types::ty::*;

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
    OpSpec::new(
        "AngularToLatLong",
        "image",
        1,
        "Convert a Debevec angular light probe to a lat-long map (outside the disc masked)",
    )
    .output_like("image", |p: AngularParams<Check>| p.image, "the lat-long map")
    .size(|_, p: AngularParams<Check>| Some((p.width as u64, p.height as u64)))
    .code_hash(crate::op_code_hash!())
    .eval(eval)
}

/// Image-plane coordinates (u, v) in [-1, 1] of direction `d` in the angular map.
pub fn angular_uv(d: [f64; 3]) -> (f64, f64) {
    let s = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if s < 1e-12 {
        // Straight forward (r = 0) or straight back (r = 1, any azimuth).
        return if d[2] < 0.0 { (0.0, 0.0) } else { (1.0, 0.0) };
    }
    let r = (-d[2]).clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
    (d[0] / s * r, d[1] / s * r)
}

/// Converts an angular probe to a `width` x `height` lat-long map.
pub fn angular_to_latlong(probe: &Image, width: usize, height: usize) -> Image {
    let c = probe.channels;
    let (pw, ph) = (probe.width as f64, probe.height as f64);
    let inside = |x: isize, y: isize| -> bool {
        if x < 0 || y < 0 || x >= probe.width as isize || y >= probe.height as isize {
            return false;
        }
        let u = 2.0 * (x as f64 + 0.5) / pw - 1.0;
        let v = 1.0 - 2.0 * (y as f64 + 0.5) / ph;
        u * u + v * v <= 1.0
    };
    let mut out = vec![0.0f32; width * height * c];
    out.par_chunks_mut(width * c).enumerate().for_each(|(y, row)| {
        let mut acc = vec![0.0f64; c];
        for x in 0..width {
            let (u, v) = angular_uv(latlong::texel_direction(x, y, width, height));
            // Continuous pixel coordinates (centres at +0.5).
            let fx = (u + 1.0) * 0.5 * pw - 0.5;
            let fy = (1.0 - v) * 0.5 * ph - 0.5;
            let tap = |sx: isize, sy: isize| inside(sx, sy).then_some((sx as usize, sy as usize));
            if bilinear::lookup(probe, fx, fy, tap, &mut acc) {
                for k in 0..c {
                    row[x * c + k] = acc[k] as f32;
                }
            }
        }
    });
    Image::from_vec(width, height, c, out)
}

fn eval(_: &mut OpContext, p: AngularParams) -> Result<Value, OpError> {
    let probe = &*p.image;
    let mut out = angular_to_latlong(probe, p.width, p.height);
    out.names = probe.names.clone();
    Ok(Value::new(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_is_the_centre_and_right_is_plus_x() {
        assert_eq!(angular_uv([0.0, 0.0, -1.0]), (0.0, 0.0));
        let (u, v) = angular_uv([1.0, 0.0, 0.0]);
        assert!((u - 0.5).abs() < 1e-12 && v.abs() < 1e-12);
        let (u, v) = angular_uv([0.0, 1.0, 0.0]);
        assert!(u.abs() < 1e-12 && (v - 0.5).abs() < 1e-12);
    }

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
