//! `Overlay(image, samples, size: 5, color: (0, 1, 0), exposure: 0)`: the seed's figures of
//! samples on a map: the image scaled by 2^exposure and clamped to [0, 1] (display range, still
//! linear: `Save` to `.png` applies the sRGB transfer), with a `size` x `size` square of `color`
//! centred on each sample's texel. The texel is found from the sample's direction, so samples
//! drawn for one resolution can be drawn on a canvas of any other.

use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;

pub static SPEC: OpSpec = OpSpec {
    name: "Overlay",
    category: "image",
    version: 1,
    doc: "Draw samples as coloured squares on a lat-long image (the seed's green squares)",
    fields: &[
        FieldSpec::input("image", &[ValueType::Image, ValueType::ScalarField], "the lat-long map or canvas"),
        FieldSpec::input("samples", &[ValueType::Samples], "the samples to draw"),
        FieldSpec {
            name: "size",
            kind: FieldKind::Int { min: 1, max: 255 },
            default: Default::Int(5),
            doc: "side of each square in pixels",
        },
        FieldSpec {
            name: "color",
            kind: FieldKind::Tuple { len: 3, min: 0.0, max: 1.0 },
            default: Default::Tuple(&[0.0, 1.0, 0.0]),
            doc: "linear RGB colour of the squares",
        },
        FieldSpec {
            name: "exposure",
            kind: FieldKind::Float { min: -64.0, max: 64.0 },
            default: Default::Float(0.0),
            doc: "exposure in stops applied to the image before clamping",
        },
    ],
    output: OutputType::Fixed(ValueType::Image),
    eval,
    content_key: None,
    check: None,
};

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let img = ctx.image("image");
    let samples = ctx.samples("samples");
    let size = ctx.params.usize("size") as isize;
    let color = ctx.params.vec3("color").map(|v| v as f32);
    let scale = 2f64.powf(ctx.params.f64("exposure")) as f32;
    let (w, h) = (img.width, img.height);
    let mut out = crate::data::Image::from_fn_rgb(w, h, |x, y| {
        img.rgb(x, y).map(|v| if v.is_nan() { 0.0 } else { (v * scale).clamp(0.0, 1.0) })
    });
    // A square of odd size is centred on the texel; an even one extends one more to the left/top.
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
    Ok(Value::image(out))
}
