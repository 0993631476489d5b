//! `SimulateBrackets(env, times, response: Srgb | Gamma22 | SCurve = Srgb, bits: 8, noise: 0,
//! seed: 1, shifts, scale: 1)`: the frames a camera with a known response would write for an
//! HDR image, and that response: the known truth for the capture tests, benchmarks and example.
//!
//! Frame `i` exposes `scale E t_i` (1 = the clip) of the image shifted by the integer
//! `shifts[2i], shifts[2i + 1]` pixels (x right, y down; the uncovered edge filled from the
//! edge), adds shot and read noise scaled by `noise` (a 32768-electron full well and 4 electrons
//! of read noise at `noise: 1`, seeded and deterministic) and quantises the response's display
//! value to `bits`-bit codes. The formulas, the `SCurve` curve's among them:
//! `maths::capture::simulate` and `maths::capture::response`. Port `response`: the true
//! response as a `curves` value (x = the codes, series R, G, B = the relative exposure of each
//! code, the middle code 1), as `CalibrateResponse` makes it.

use crate::engine::fields::{Check, Input};
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::capture::response::{Known, Response};
use crate::maths::capture::simulate::{simulate, Simulation};
use crate::values::brackets::Brackets;
use crate::values::ty::*;
use crate::values::{Curves, Image};

crate::params! {
    pub struct SimulateBracketsParams {
        /// the HDR image to photograph (RGB; relative radiance)
        #[input(&[IMAGE_T])]
        pub env: Input<Image>,
        /// exposure times in seconds, one per frame (at least 2, all different)
        #[range(1e-9, 1e9)]
        pub times: Vec<f64>,
        /// the camera's response: Srgb, Gamma22 or SCurve (a film-like S curve)
        pub response: Known = Known::Srgb,
        /// bits per channel of the codes: 8 or 16
        #[range(8, 16)]
        pub bits: u32 = 8,
        /// shot and read noise scale (0: none; 1: a 32768-electron full well, 4 electrons read noise)
        #[range(0.0, 1000.0)]
        pub noise: f64 = 0.0,
        /// the noise's seed
        pub seed: u64 = 1,
        /// integer shifts per frame, [dx0, dy0, dx1, dy1, ...] in pixels (x right, y down)
        pub shifts: Vec<f64> = Vec::new(),
        /// radiance scale: the sensor's exposure is scale * E * t, clipping at 1
        #[range(1e-30, 1e30)]
        pub scale: f64 = 1.0,
    }
}

const BRACKETS: Port<Brackets> = Port::new("brackets");
const RESPONSE: Port<Curves> = Port::new("response");

pub fn spec() -> OpSpec {
    Op::new(
        "SimulateBrackets",
        1,
        "Synthetic bracketed exposures of an HDR image by a camera of known response, noise and shifts (the truth for tests)",
        eval,
    )
    .port(BRACKETS, BRACKETS_T, "the frames as codes, shortest exposure first")
    .port(RESPONSE, CURVES_T, "the true response: relative exposure per code, the middle code 1")
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: SimulateBracketsParams<Check>) -> Result<(), CheckProblem> {
    if p.bits != 8 && p.bits != 16 {
        return Err(CheckProblem::at(SimulateBracketsParams::bits, format!("bits is 8 or 16, not {}", p.bits)));
    }
    if p.times.len() < 2 {
        return Err(CheckProblem::at(SimulateBracketsParams::times, "a bracket needs at least 2 exposure times"));
    }
    let mut sorted = p.times.clone();
    sorted.sort_by(f64::total_cmp);
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return Err(CheckProblem::at(SimulateBracketsParams::times, "two frames have the same exposure time"));
    }
    shifts(&p.shifts, p.times.len()).map_err(|e| CheckProblem::at(SimulateBracketsParams::shifts, e))?;
    Ok(())
}

/// The shifts as (dx, dy) pairs, or why they are not one integer pair per frame.
fn shifts(v: &[f64], frames: usize) -> Result<Vec<(i64, i64)>, String> {
    if v.is_empty() {
        return Ok(vec![]);
    }
    if v.len() != 2 * frames {
        return Err(format!("{} numbers for {frames} frames: give dx, dy for each frame", v.len()));
    }
    if let Some(s) = v.iter().find(|s| s.fract() != 0.0 || s.abs() > 1e6) {
        return Err(format!("shift {s} is not a whole number of pixels"));
    }
    Ok(v.chunks_exact(2).map(|c| (c[0] as i64, c[1] as i64)).collect())
}

fn eval(_: &mut OpContext, p: SimulateBracketsParams) -> Result<Outputs, OpError> {
    let sim = Simulation {
        times: p.times.clone(),
        curve: p.response,
        bits: p.bits as u8,
        noise: p.noise,
        seed: p.seed,
        shifts: shifts(&p.shifts, p.times.len()).map_err(OpError::Invalid)?,
        scale: p.scale,
    };
    let brackets = simulate(&p.env, &sim).map_err(OpError::Invalid)?;
    let truth =
        Response::known(p.response, p.bits as u8).to_curves(&format!("{} response ({} bits)", p.response, p.bits));
    Ok(Outputs::new().port(BRACKETS, brackets).port(RESPONSE, truth))
}
