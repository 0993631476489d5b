//! `PhongSample(exponent, count, seed, normal, view, sequence, width, height)`: directions from
//! the modified Phong lobe (Lafortune and Willems 1994) around the mirror direction of `view`
//! about `normal`: cos(alpha) = u1^(1/(s+1)), phi = 2*pi*u2, pdf (s+1)/(2*pi) * cos^s(alpha).
//! Texel indices refer to a `width` x `height` lat-long grid, so `Overlay` can draw them.
//!
//! Defaults: normal and view both face forward (-Z, the centre column of a lat-long map), so
//! the lobe sits undistorted in the middle of the canvas, as in the seed's figures.

use rayon::prelude::*;

use crate::data::{Sample, SampleSet};
use crate::engine::op::{Default, FieldKind, FieldSpec, OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::{Value, ValueType};
use crate::geometry::latlong;
use crate::maths::{phong, sequences};

use super::{count_field, sequence_of, SEED_FIELD, SEQUENCE_FIELD};

pub static SPEC: OpSpec = OpSpec {
    name: "PhongSample",
    category: "sampling",
    version: 1,
    doc: "Draw directions from a modified Phong lobe cos^s around the mirror direction",
    fields: &[
        FieldSpec {
            name: "exponent",
            kind: FieldKind::Float { min: 0.0, max: 1e9 },
            default: Default::Required,
            doc: "Phong exponent s (0 = cosine-free uniform hemisphere lobe)",
        },
        count_field(1024),
        SEED_FIELD,
        FieldSpec {
            name: "normal",
            kind: FieldKind::Tuple { len: 3, min: -1e6, max: 1e6 },
            default: Default::Tuple(&[0.0, 0.0, -1.0]),
            doc: "surface normal (normalised here)",
        },
        FieldSpec {
            name: "view",
            kind: FieldKind::Tuple { len: 3, min: -1e6, max: 1e6 },
            default: Default::Tuple(&[0.0, 0.0, -1.0]),
            doc: "direction from the surface towards the viewer (normalised here)",
        },
        SEQUENCE_FIELD,
        FieldSpec {
            name: "width",
            kind: FieldKind::Int { min: 1, max: 1 << 15 },
            default: Default::Int(512),
            doc: "lat-long grid width for texel indices",
        },
        FieldSpec {
            name: "height",
            kind: FieldKind::Int { min: 1, max: 1 << 15 },
            default: Default::Int(256),
            doc: "lat-long grid height for texel indices",
        },
    ],
    output: OutputType::Fixed(ValueType::Samples),
    eval,
    content_key: None,
    check: None,
};

fn normalised(v: [f64; 3], what: &str) -> Result<[f64; 3], OpError> {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if !(len > 1e-12) || !len.is_finite() {
        return Err(OpError::Invalid(format!("{what} must be a non-zero vector, got {v:?}")));
    }
    Ok(v.map(|c| c / len))
}

fn eval(ctx: &OpContext) -> Result<Value, OpError> {
    let normal = normalised(ctx.params.vec3("normal"), "normal")?;
    let view = normalised(ctx.params.vec3("view"), "view")?;
    let axis = phong::mirror(view, normal);
    let s = ctx.params.f64("exponent");
    let (w, h) = (ctx.params.usize("width"), ctx.params.usize("height"));
    let points = sequences::generate(sequence_of(ctx), ctx.params.usize("count"), ctx.params.int("seed") as u64);
    let samples: Vec<Sample> = points
        .par_iter()
        .map(|&[u1, u2]| {
            let (d, pdf) = phong::sample_lobe(axis, s, u1, u2);
            let (theta, phi) = latlong::angles(d);
            let (x, y) = latlong::texel_of_direction(d, w, h);
            Sample::new(x, y, theta, phi, d, pdf)
        })
        .collect();
    Ok(Value::Samples(std::sync::Arc::new(SampleSet { width: w as u32, height: h as u32, samples })))
}
