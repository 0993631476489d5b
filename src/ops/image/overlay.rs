//! `Overlay(image, samples, size: 5, color: (0, 1, 0), exposure: 0)`: the seed's figures of
//! samples on a map: the image scaled by 2^exposure and clamped to [0, 1] (display range, still
//! linear: `Save` to `.png` applies the sRGB transfer), with a `size` x `size` square of `color`
//! centred on each sample's texel. The texel is found from the sample's direction, so samples
//! drawn for one resolution can be drawn on a canvas of any other.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Persist};
use crate::engine::params::Rgb;
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::geometry::latlong;
use crate::values::ty::*;
use crate::values::{Image, SampleSet};

crate::params! {
    pub struct OverlayParams {
        /// the lat-long map or canvas
        #[input(ANY_IMAGE)]
        pub image: Input<Image>,
        /// the samples to draw
        #[input(&[SAMPLES_T])]
        pub samples: Input<SampleSet>,
        /// side of each square in pixels
        #[range(1, 255)]
        pub size: usize = 5,
        /// linear RGB colour of the squares
        #[range(0.0, 1.0)]
        pub color: Rgb = Rgb([0.0, 1.0, 0.0]),
        /// exposure in stops applied to the image before clamping
        #[range(-64.0, 64.0)]
        pub exposure: f64 = 0.0,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Overlay", 1, "Draw samples as coloured squares on a lat-long image (the seed's green squares)", eval)
        .output("image", IMAGE_T, "the image with the samples drawn (RGB)")
        .size(|_, p| p.image.size)
        .persist(Persist::IfSmall)
        .into()
}

fn eval(_: &mut OpContext, p: OverlayParams) -> Result<Value, OpError> {
    let (img, samples) = (&*p.image, &*p.samples);
    let size = p.size as isize;
    let color = p.color.f32();
    let scale = 2f64.powf(p.exposure) as f32;
    let (w, h) = (img.width, img.height);
    let mut out = Image::from_fn_rgb(w, h, |x, y| {
        img.rgb(x, y).map(|v| if v.is_nan() { 0.0 } else { (v * scale).clamp(0.0, 1.0) })
    });
    let before = size / 2;
    for s in &samples.samples {
        let (cx, cy) = if s.x < samples.width
            && s.y < samples.height
            && samples.width as usize == w
            && samples.height as usize == h
        {
            (s.x as usize, s.y as usize)
        } else {
            latlong::texel_of_direction([s.dir[0] as f64, s.dir[1] as f64, s.dir[2] as f64], w, h)
        };
        for dy in 0..size {
            let y = cy as isize - before + dy;
            if y < 0 || y >= h as isize {
                continue;
            }
            for dx in 0..size {
                let x = cx as isize - before + dx;
                if x < 0 || x >= w as isize {
                    continue;
                }
                out.pixel_mut(x as usize, y as usize).copy_from_slice(&color);
            }
        }
    }
    Ok(Value::new(out))
}
