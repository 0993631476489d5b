//! `AlignBrackets(brackets, max_shift: 64)`: moves every frame of a hand-held bracket onto the
//! middle exposure by Ward's median threshold bitmap alignment (translation only), exactly as
//! OpenCV's `AlignMTB` with its defaults (`max_bits` 6, `exclude_range` 4, `cut` false) but for
//! ties (a flat frame stays put instead of moving by (-63, -63)) and the fill: see
//! `maths::capture::mtb` (the search) and `maths::capture::align` (the frames).
//!
//! The reference is the frame at index `n / 2` of the frames sorted by exposure time (OpenCV's
//! pivot). Each frame keeps its size: pixels its shift uncovered are filled from the nearest edge
//! and marked 0 in the frame's `covered` mask, which `MergeBrackets` gives no weight.
//! `max_shift` sets `max_bits = ceil(log2(max_shift))` (64: 6); shifts reach `2^max_bits - 1`
//! pixels, fewer on images too small for the pyramid.
//!
//! Port `shifts` (metrics): `reference` (the reference's index), `levels` (the pyramid levels
//! searched), then `dx_k`, `dy_k` for every frame k in order: frame k was moved by (dx_k, dy_k)
//! pixels, x right and y down, `aligned(x, y) = frame(x - dx_k, y - dy_k)`. Tests: frames at five
//! exposures moved by known offsets up to 30 pixels come back with exactly those shifts.

use crate::engine::fields::Input;
use crate::engine::op::{OpContext, OpError, OpSpec, Outputs};
use crate::engine::typed_op::{Op, Port};
use crate::maths::capture::align::{align_brackets, max_bits_for, reference_index, Pairing};
use crate::maths::capture::mtb::max_level;
use crate::values::ty::*;
use crate::values::{Brackets, Metrics};

crate::params! {
    pub struct AlignBracketsParams {
        /// the bracketed frames (as LoadBrackets gives them)
        #[input(&[BRACKETS_T])]
        pub brackets: Input<Brackets>,
        /// the largest shift to search for, pixels: max_bits = ceil(log2(max_shift)) (64: OpenCV's 6)
        #[range(1, 32768)]
        pub max_shift: u32 = 64,
        /// Chained: each frame against its neighbour towards the middle one, the shifts added; Reference: each against the middle frame, as OpenCV's AlignMTB
        pub pairing: Pairing = Pairing::Chained,
    }
}

const BRACKETS: Port<Brackets> = Port::new("brackets");
const SHIFTS: Port<Metrics> = Port::new("shifts");

pub fn spec() -> OpSpec {
    Op::new(
        "AlignBrackets",
        1,
        "Align bracketed frames onto the middle exposure by median threshold bitmaps (Ward 2003, as OpenCV's AlignMTB)",
        eval,
    )
    .port(BRACKETS, BRACKETS_T, "the frames, each moved onto the reference; uncovered pixels filled from the edge and marked in its coverage mask")
    .port(SHIFTS, METRICS_T, "reference, levels, and dx_k, dy_k: the pixels frame k was moved by (x right, y down)")
    .into()
}

fn eval(_: &mut OpContext, p: AlignBracketsParams) -> Result<Outputs, OpError> {
    let mut b = p.brackets.take();
    if b.frames.is_empty() {
        return Err(OpError::Invalid("the bracket has no frames to align".into()));
    }
    let shifts = align_brackets(&mut b, p.max_shift, p.pairing);
    let levels = max_level(b.width, b.height, max_bits_for(p.max_shift)) + 1;
    let mut fields = vec![
        ("reference".to_string(), reference_index(b.frames.len()) as f64),
        ("levels".to_string(), levels.max(0) as f64),
    ];
    for (k, (dx, dy)) in shifts.iter().enumerate() {
        fields.push((format!("dx_{k}"), *dx as f64));
        fields.push((format!("dy_{k}"), *dy as f64));
    }
    Ok(Outputs::new().port(BRACKETS, b).port(SHIFTS, Metrics { fields }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::brackets::{Codes, Frame};

    #[test]
    fn the_spec_declares_both_ports() {
        let s = spec();
        assert_eq!(s.name, "AlignBrackets");
        let names: Vec<&str> = s.outputs.iter().map(|o| o.name).collect();
        assert_eq!(names, ["brackets", "shifts"]);
        // The maths is tested in maths::capture::align; a bracket round-trips its shape here.
        let f = |t: f64| Frame { name: format!("{t}"), time: t, codes: Codes::U8(vec![9; 12]), covered: None };
        let mut b = Brackets::new(2, 2, 8, vec![f(1.0), f(2.0)]).unwrap();
        assert_eq!(align_brackets(&mut b, 64, Pairing::Chained), vec![(0, 0), (0, 0)]);
    }
}
