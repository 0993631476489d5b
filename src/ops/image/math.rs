//! `Math(a, b, op, value: 0)`: per-sample arithmetic, out = a (op) b.
//!
//! | op  | out          |
//! |-----|--------------|
//! | Add | a + b        |
//! | Sub | a - b        |
//! | Mul | a * b        |
//! | Div | a / b        |
//! | Min | min(a, b)    |
//! | Max | max(a, b)    |
//! | Pow | a^b          |
//!
//! **Operands.** `b` is an optional input:
//! - not wired: every sample of `a` is combined with the number `value` (the scalar broadcast);
//! - a scalar field (one channel): its sample at (x, y) is combined with every channel of `a`;
//! - an image: each channel of `a` is combined with the channel of `b` of the same name (so an
//!   RGBA `a` takes an RGB `b`); a channel of `a` that `b` lacks is an error naming both lists.
//!
//! `b` must have the size of `a`. `value` given while `b` is wired is a validation error (it would
//! be ignored). The output has `a`'s size, channel names and type.
//!
//! **Alpha.** In an image of two or more channels, the channel named `A` is coverage, not a
//! colour: it is passed through from `a` unchanged (`b`'s alpha, if any, is not used). A scalar
//! field is always computed, whatever its name, so `Math(a: "split.A", ...)` works on alpha.
//!
//! **Numerics.** Each result is computed in f64 from the f32 samples and rounded once to f32,
//! which for Add, Sub, Mul and Div is exactly the correctly rounded f32 operation (f64 has more
//! than 2 * 24 + 2 bits; Figueroa 1995, "When is double rounding innocuous?"), and for Pow
//! avoids f32 `powf`'s error. IEEE 754 rules apply unchanged, nothing is clamped: x/0 is
//! +-Inf, 0/0, Inf - Inf, 0 * Inf and a negative number to a non-integer power are NaN, and a
//! result beyond f32 range is +-Inf. Min and Max return the other operand when one is NaN
//! (IEEE 754 minNum/maxNum, Rust's `f64::min`/`max`). NaN then propagates downstream, where
//! `BuildCdf` names the first bad texel; clamp with `Max`/`Min` against a `value` to avoid it.

use rayon::prelude::*;

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Persist};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::values::ty::*;
use crate::values::Image;

crate::choice! {
    /// The operation.
    pub enum MathOp { Add, Sub, Mul, Div, Min, Max, Pow }
}

crate::params! {
    pub struct MathParams {
        /// the first operand (its size, channels and type are the output's)
        #[input(ANY_IMAGE)]
        pub a: Input<Image>,
        /// the second operand: a scalar field broadcasts over a's channels; unwired: `value`
        #[input(ANY_IMAGE)]
        pub b: Option<Input<Image>>,
        /// Add, Sub, Mul, Div, Min, Max or Pow: out = a (op) b
        pub op: MathOp,
        /// the b operand when b is not wired (broadcast to every sample of a)
        #[range(-1e30, 1e30)]
        pub value: f64 = 0.0,
    }
}

pub fn spec() -> OpSpec {
    Op::new("Math", 1, "Per-sample a (op) b: Add Sub Mul Div Min Max Pow; b an image, a scalar field or a number", eval)
        .output_computed("image", "the type of `a`", |_, p| Ok(p.a.ty), "a (op) b")
        .size(|_, p| p.a.size)
        .persist(Persist::IfSmall)
        .check(check)
        .into()
}

fn check(_: &CheckContext, p: MathParams<Check>) -> Result<(), CheckProblem> {
    if p.b.is_some() && p.value != 0.0 {
        return Err(CheckProblem::at(
            MathParams::value,
            "`value` is used only when `b` is not wired: remove one of them",
        ));
    }
    Ok(())
}

/// One sample of the result.
#[inline]
pub fn apply(op: MathOp, a: f32, b: f32) -> f32 {
    let (a, b) = (a as f64, b as f64);
    (match op {
        MathOp::Add => a + b,
        MathOp::Sub => a - b,
        MathOp::Mul => a * b,
        MathOp::Div => a / b,
        MathOp::Min => a.min(b),
        MathOp::Max => a.max(b),
        MathOp::Pow => a.powf(b),
    }) as f32
}

/// Where each channel of `a` takes its second operand from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Operand {
    /// Alpha: passed through.
    Keep,
    Number(f32),
    /// This channel of `b`.
    Channel(usize),
}

fn operands(a: &Image, b: Option<&Image>, value: f64) -> Result<Vec<Operand>, OpError> {
    if let Some(b) = b {
        if (b.width, b.height) != (a.width, a.height) {
            return Err(OpError::Invalid(format!(
                "b is {}x{}, but a is {}x{}: they must have the same size",
                b.width, b.height, a.width, a.height
            )));
        }
    }
    a.names
        .iter()
        .map(|name| match b {
            _ if a.channels > 1 && name == "A" => Ok(Operand::Keep),
            None => Ok(Operand::Number(value as f32)),
            Some(b) if b.channels == 1 => Ok(Operand::Channel(0)),
            Some(b) => b.channel_index(name).map(Operand::Channel).ok_or_else(|| {
                OpError::Invalid(format!(
                    "b has no channel {name:?} (a: {}; b: {}); a scalar field b applies to every channel",
                    a.names.join(", "),
                    b.names.join(", ")
                ))
            }),
        })
        .collect()
}

/// `a (op) b` in place in `a`; `b: None` uses `value`.
pub fn math(a: &mut Image, b: Option<&Image>, op: MathOp, value: f64) -> Result<(), OpError> {
    let plan = operands(a, b, value)?;
    let (c, w) = (a.channels, a.width);
    if w == 0 {
        return Ok(());
    }
    a.data.par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
        let b_row = b.map(|b| b.row(y));
        let bc = b.map_or(0, |b| b.channels);
        for (x, px) in row.chunks_exact_mut(c).enumerate() {
            for (k, v) in px.iter_mut().enumerate() {
                *v = match plan[k] {
                    Operand::Keep => *v,
                    Operand::Number(n) => apply(op, *v, n),
                    Operand::Channel(j) => apply(op, *v, b_row.expect("a channel operand implies b")[x * bc + j]),
                };
            }
        }
    });
    Ok(())
}

fn eval(_: &mut OpContext, p: MathParams) -> Result<Value, OpError> {
    // `a`'s buffer is reused when this node is its last consumer.
    let mut a = p.a.take();
    math(&mut a, p.b.as_deref(), p.op, p.value)?;
    Ok(Value::new(a))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(names: &[&str], data: Vec<f32>) -> Image {
        let n: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let w = data.len() / n.len();
        Image::with_names(w, 1, n, data)
    }

    #[test]
    fn each_op_matches_its_closed_form() {
        let cases = [
            (MathOp::Add, 3.0, 2.0, 5.0),
            (MathOp::Sub, 3.0, 2.0, 1.0),
            (MathOp::Mul, 3.0, 2.0, 6.0),
            (MathOp::Div, 3.0, 2.0, 1.5),
            (MathOp::Min, 3.0, 2.0, 2.0),
            (MathOp::Max, 3.0, 2.0, 3.0),
            (MathOp::Pow, 3.0, 2.0, 9.0),
            (MathOp::Pow, -2.0, 2.0, 4.0),
            (MathOp::Pow, 4.0, 0.5, 2.0),
        ];
        for (op, a, b, want) in cases {
            assert_eq!(apply(op, a, b), want, "{op:?}");
        }
        // One rounding: the correctly rounded f32 result.
        assert_eq!(apply(MathOp::Add, 0.1, 0.2), 0.1f32 + 0.2f32);
        assert_eq!(apply(MathOp::Div, 1.0, 3.0), 1.0f32 / 3.0f32);
    }

    #[test]
    fn ieee_special_cases_are_kept_not_clamped() {
        assert_eq!(apply(MathOp::Div, 1.0, 0.0), f32::INFINITY);
        assert_eq!(apply(MathOp::Div, -1.0, 0.0), f32::NEG_INFINITY);
        assert!(apply(MathOp::Div, 0.0, 0.0).is_nan());
        assert!(apply(MathOp::Sub, f32::INFINITY, f32::INFINITY).is_nan());
        assert!(apply(MathOp::Pow, -8.0, 1.0 / 3.0).is_nan());
        assert_eq!(apply(MathOp::Pow, 0.0, 0.0), 1.0);
        assert_eq!(apply(MathOp::Mul, 3e38, 10.0), f32::INFINITY);
        assert_eq!(apply(MathOp::Min, f32::NAN, 2.0), 2.0);
        assert_eq!(apply(MathOp::Max, 2.0, f32::NAN), 2.0);
    }

    #[test]
    fn scalar_broadcast_and_alpha_passes_through() {
        let mut a = img(&["R", "G", "B", "A"], vec![1.0, 2.0, 4.0, 0.5, 8.0, 16.0, 32.0, 1.0]);
        math(&mut a, None, MathOp::Mul, 0.5).unwrap();
        assert_eq!(a.data, vec![0.5, 1.0, 2.0, 0.5, 4.0, 8.0, 16.0, 1.0]);
        let mask = img(&["Y"], vec![2.0, 0.0]);
        math(&mut a, Some(&mask), MathOp::Mul, 0.0).unwrap();
        assert_eq!(a.data, vec![1.0, 2.0, 4.0, 0.5, 0.0, 0.0, 0.0, 1.0]);
        // A scalar field named A is computed (it is not the alpha of anything).
        let mut alpha = img(&["A"], vec![0.5, 1.0]);
        math(&mut alpha, None, MathOp::Sub, 1.0).unwrap();
        assert_eq!(alpha.data, vec![-0.5, 0.0]);
    }

    #[test]
    fn images_pair_channels_by_name() {
        let mut a = img(&["R", "G", "B", "A"], vec![10.0, 20.0, 30.0, 0.25]);
        let b = img(&["B", "G", "R"], vec![3.0, 2.0, 1.0]);
        math(&mut a, Some(&b), MathOp::Sub, 0.0).unwrap();
        assert_eq!(a.data, vec![9.0, 18.0, 27.0, 0.25]);
        let same = a.clone();
        math(&mut a, Some(&same), MathOp::Sub, 0.0).unwrap();
        assert_eq!(a.data, vec![0.0, 0.0, 0.0, 0.25]);
        let xyz = img(&["X", "Y", "Z"], vec![1.0, 1.0, 1.0]);
        let e = math(&mut a, Some(&xyz), MathOp::Add, 0.0).unwrap_err().to_string();
        assert_eq!(e, "b has no channel \"R\" (a: R, G, B, A; b: X, Y, Z); a scalar field b applies to every channel");
        let wide = img(&["Y"], vec![1.0, 2.0]);
        let e = math(&mut a, Some(&wide), MathOp::Add, 0.0).unwrap_err().to_string();
        assert_eq!(e, "b is 2x1, but a is 1x1: they must have the same size");
    }
}
