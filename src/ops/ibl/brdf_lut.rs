//! `BrdfLut(size, samples, multiscatter: false)`: the split-sum DFG texture (Karis 2013) for GGX
//! with the Smith height-correlated visibility `V = 0.5 / (n.l sqrt(n.v^2 (1 - a^2) + a^2) + n.v
//! sqrt(n.l^2 (1 - a^2) + a^2))` (Heitz 2014), importance sampled (`samples` Hammersley points,
//! pdf `D(h) n.h`). Column x: `n.v = (x + 0.5) / size`; row y (row 0 at the top): perceptual
//! roughness `(y + 0.5) / size`, alpha = roughness^2. Two channels:
//!
//! - `multiscatter: false`: `R` = scale `E[(1 - Fc) Gv]`, `G` = bias `E[Fc Gv]`, with
//!   `Fc = (1 - v.h)^5`, `Gv = 4 V (n.l)(v.h) / (n.h)`: `specular = f0 R + f90 G`.
//! - `multiscatter: true`: Filament's and Fdez-Aguera's form, `R = E[Fc Gv]`, `G = E[Gv]`:
//!   `specular = mix(R, G, f0)` and the multiscatter compensation `1 + f0 (1 / G - 1)`.
//!
//! Tested: scale + bias (or `G`) <= 1 everywhere (to 1e-3), and at roughness -> 0 scale + bias -> 1
//! and bias -> (1 - n.v)^5 (the closed form of a mirror). Formulas in `maths::ggx`.

use crate::engine::fields::Check;
use crate::engine::op::{OpContext, OpError, OpSpec, OutputType};
use crate::engine::value::Value;
use crate::maths::ggx::{brdf_lut, LobeSequence};
use crate::values::ty::*;

crate::params! {
    pub struct BrdfLutParams {
        /// width and height in texels
        #[range(1, 4096)]
        pub size: usize = 128,
        /// importance samples per texel (Hammersley points)
        #[range(1, 1048576)]
        pub samples: usize = 1024,
        /// false: (scale, bias); true: Filament's multiscatter (`E[Fc Gv]`, `E[Gv]`)
        pub multiscatter: bool = false,
    }
}

pub fn spec() -> OpSpec {
    OpSpec::new(
        "BrdfLut",
        "ibl",
        1,
        "Split-sum DFG texture (R, G) = (scale, bias) of GGX with Smith height-correlated visibility, x = n.v, y = roughness",
    )
    .output("image", OutputType::Fixed(IMAGE_T), "the size x size two-channel texture (R, G)")
    .size(|_, p: BrdfLutParams<Check>| Some((p.size as u64, p.size as u64)))
    .code_hash(crate::op_code_hash!())
    .eval(eval)
}

fn eval(_: &mut OpContext, p: BrdfLutParams) -> Result<Value, OpError> {
    Ok(Value::new(brdf_lut(p.size, p.samples, LobeSequence::Hammersley, p.multiscatter)))
}
