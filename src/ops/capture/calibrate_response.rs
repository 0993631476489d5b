//! `CalibrateResponse(brackets, method: Debevec | Robertson = Debevec, lambda: 10, samples: 70)`:
//! the camera's response per channel, recovered from the brackets themselves.
//!
//! `Debevec`: Debevec and Malik's (1997) least squares over `samples` pixels on OpenCV's grid,
//! with the hat weight and smoothness `lambda` (`maths::capture::debevec`). `Robertson`:
//! Robertson et al.'s (2003) iteration over every pixel, as OpenCV's `CalibrateRobertson`
//! (30 iterations at most, threshold 0.01; `maths::capture::robertson`). 16-bit codes are
//! calibrated in 256 bins and interpolated. Output `response`: a `curves` value, x = the codes
//! `0..=max`, series R, G, B = the relative exposure each code stands for (`exp(g(z))`), the
//! middle code 1, non-decreasing, so that `MergeBrackets` takes it. Tests: synthetic sRGB,
//! gamma 2.2 and S-curve brackets recover their response within the bounds stated in
//! `maths::capture::tests`.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::capture::debevec::debevec;
use crate::maths::capture::robertson::robertson;
use crate::values::brackets::Brackets;
use crate::values::ty::*;

crate::choice! {
    /// How the response is recovered.
    pub enum Method { Debevec, Robertson }
}

crate::params! {
    pub struct CalibrateResponseParams {
        /// the bracketed frames (at least 2)
        #[input(&[BRACKETS_T])]
        pub brackets: Input<Brackets>,
        /// Debevec (least squares over sample pixels) or Robertson (iteration over every pixel)
        pub method: Method = Method::Debevec,
        /// Debevec: the smoothness weight
        #[range(0.0, 1e6)]
        pub lambda: f64 = 10.0,
        /// Debevec: the number of sample pixels (a regular grid, as OpenCV's)
        #[range(2, 100_000)]
        pub samples: usize = 70,
    }
}

/// Robertson's iteration limits, OpenCV's defaults.
const ROBERTSON_MAX_ITER: usize = 30;
const ROBERTSON_THRESHOLD: f64 = 0.01;

pub fn spec() -> OpSpec {
    Op::new(
        "CalibrateResponse",
        1,
        "Recover a camera's response curves from bracketed exposures (Debevec or Robertson)",
        eval,
    )
    .output("response", CURVES_T, "relative exposure per code and channel (R, G, B), the middle code 1")
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: CalibrateResponseParams<Check>) -> Result<(), CheckProblem> {
    if p.method == Method::Robertson && p.samples != 70 {
        return Err(CheckProblem::at(
            CalibrateResponseParams::samples,
            "samples is Debevec's; Robertson uses every pixel",
        ));
    }
    Ok(())
}

fn eval(_: &mut OpContext, p: CalibrateResponseParams) -> Result<Value, OpError> {
    let b: &Brackets = &p.brackets;
    super::require_frames(b, 2)?;
    let r = match p.method {
        Method::Debevec => debevec(b, p.lambda, p.samples),
        Method::Robertson => robertson(b, ROBERTSON_MAX_ITER, ROBERTSON_THRESHOLD),
    }
    .map_err(|e| OpError::Invalid(format!("calibrating the response: {e}")))?;
    Ok(Value::new(r.to_curves(&format!("{} response ({} bits)", p.method, b.bit_depth))))
}
