//! `BrdfLut(size, samples, multiscatter: false, brdf: Ggx)`: a split-sum texture, x = n.v, y =
//! roughness. Column x: `n.v = (x + 0.5) / size`; row y (row 0 at the top): perceptual roughness
//! `(y + 0.5) / size`, as glTF-IBL-Sampler lays out its LUTs.
//!
//! `brdf: Ggx` (the default): the DFG texture (Karis 2013) for GGX with the Smith
//! height-correlated visibility `V = 0.5 / (n.l sqrt(n.v^2 (1 - a^2) + a^2) + n.v
//! sqrt(n.l^2 (1 - a^2) + a^2))` (Heitz 2014), alpha = roughness^2, importance sampled
//! (`samples` Hammersley points, pdf `D(h) n.h`). Two channels:
//!
//! - `multiscatter: false`: `R` = scale `E[(1 - Fc) Gv]`, `G` = bias `E[Fc Gv]`, with
//!   `Fc = (1 - v.h)^5`, `Gv = 4 V (n.l)(v.h) / (n.h)`: `specular = f0 R + f90 G`.
//! - `multiscatter: true`: Filament's and Fdez-Aguera's form, `R = E[Fc Gv]`, `G = E[Gv]`:
//!   `specular = mix(R, G, f0)` and the multiscatter compensation `1 + f0 (1 / G - 1)`.
//!
//! Tested: scale + bias (or `G`) <= 1 everywhere (to 1e-3), and at roughness -> 0 scale + bias -> 1
//! and bias -> (1 - n.v)^5 (the closed form of a mirror). Formulas in `maths::brdf::ggx`.
//!
//! `brdf: Charlie`: the sheen LUT the glTF Sample Viewer reads (`u_CharlieLUT`, `.b`, times the
//! sheen colour and the Charlie chain), as glTF-IBL-Sampler's `LUT()` computes it for its Charlie
//! distribution: Estevez and Kulla's sheen distribution, Ashikhmin's visibility, `samples`
//! Hammersley points in the sampler's order. Three channels, (R, G, B) = (0, 0, LUT), as the
//! sampler writes them; values reach 2.4 at grazing n.v and low roughness, which a PNG clamps to 1
//! as the sampler's 8-bit file does. Formula, sources and tests in `maths::brdf::charlie`.
//! `multiscatter` is GGX's and is refused with Charlie.

use crate::engine::fields::Check;
use crate::engine::op::{CheckContext, CheckProblem, OpContext, OpError, OpSpec};
use crate::engine::typed_op::Op;
use crate::engine::value::Value;
use crate::maths::brdf::ggx::LobeSequence;
use crate::maths::brdf::specular_lobe::SpecularBrdf;
use crate::maths::ibl::luts::{brdf_lut, charlie_lut};
use crate::values::ty::*;

crate::params! {
    pub struct BrdfLutParams {
        /// width and height in texels
        #[range(1, 4096)]
        pub size: usize = 128,
        /// importance samples per texel (Hammersley points)
        #[range(1, 1048576)]
        pub samples: usize = 1024,
        /// (brdf: Ggx) false: (scale, bias); true: Filament's multiscatter (`E[Fc Gv]`, `E[Gv]`)
        pub multiscatter: bool = false,
        /// Ggx: the DFG texture (R, G); Charlie: glTF-IBL-Sampler's sheen LUT in B (R = G = 0), as the glTF Sample Viewer reads it
        pub brdf: SpecularBrdf = SpecularBrdf::Ggx,
    }
}

pub fn spec() -> OpSpec {
    Op::new(
        "BrdfLut",
        1,
        "Split-sum LUT, x = n.v, y = roughness: GGX's DFG (R, G) = (scale, bias) with Smith height-correlated visibility, or the Charlie sheen LUT in B",
        eval,
    )
    .output("image", IMAGE_T, "the size x size texture: (R, G) for Ggx, (R, G, B) = (0, 0, LUT) for Charlie")
    .size(|_, p| Some((p.size as u64, p.size as u64)))
    .check(check)
    .into()
}

fn check(_: &CheckContext, p: BrdfLutParams<Check>) -> Result<(), CheckProblem> {
    if p.multiscatter && p.brdf != SpecularBrdf::Ggx {
        return Err(CheckProblem::at(
            BrdfLutParams::multiscatter,
            format!("multiscatter is read only with brdf: Ggx (this node has {})", p.brdf),
        ));
    }
    Ok(())
}

fn eval(_: &mut OpContext, p: BrdfLutParams) -> Result<Value, OpError> {
    Ok(Value::new(match p.brdf {
        SpecularBrdf::Ggx => brdf_lut(p.size, p.samples, LobeSequence::Hammersley, p.multiscatter),
        SpecularBrdf::Charlie => charlie_lut(p.size, p.samples),
    }))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::engine::scheduler::{self, RunOptions, Silent};
    use crate::maths::brdf::charlie::charlie_lut_texel;
    use crate::maths::brdf::ggx::{points, LobeSequence};
    use crate::values::Image;
    use crate::Pipeline;

    fn lut(text: &str) -> Result<Image, String> {
        let registry = crate::ops::builtin_registry();
        let p = Pipeline::parse(text, "test.ron", Path::new("."), &registry, &[]).map_err(|e| e.to_string())?;
        let dir = std::env::temp_dir().join(format!("hdrflow-brdf-lut-{}", std::process::id()));
        let options =
            RunOptions { targets: vec!["lut".into()], out_dir: dir, cache: None, jobs: Some(1), observer: &Silent };
        let out = scheduler::run(&p, &options).map_err(|e| e.to_string())?;
        Ok(out.values["lut"].get::<Image>().expect("an image").clone())
    }

    /// `brdf: Charlie` gives (0, 0, LUT) at the texel centres, n.v along the row and roughness
    /// down the columns; the default stays the two-channel GGX texture.
    #[test]
    fn charlie_writes_the_sheen_lut_in_blue_at_texel_centres() {
        let img = lut(r#"(nodes: { "lut": BrdfLut(size: 4, samples: 64, brdf: Charlie) })"#).unwrap();
        assert_eq!((img.width, img.height, img.names.clone()), (4, 4, vec!["R".into(), "G".into(), "B".into()]));
        let pts = points(LobeSequence::Hammersley, 64);
        for y in 0..4 {
            for x in 0..4 {
                let want = charlie_lut_texel((x as f64 + 0.5) / 4.0, (y as f64 + 0.5) / 4.0, &pts) as f32;
                assert_eq!(img.pixel(x, y), &[0.0, 0.0, want][..], "({x}, {y})");
            }
        }
        let ggx = lut(r#"(nodes: { "lut": BrdfLut(size: 4, samples: 64) })"#).unwrap();
        assert_eq!(ggx.names, ["R", "G"]);
    }

    #[test]
    fn multiscatter_with_charlie_is_refused_naming_the_field() {
        let e =
            lut(r#"(nodes: { "lut": BrdfLut(size: 4, samples: 64, multiscatter: true, brdf: Charlie) })"#).unwrap_err();
        assert!(e.contains("multiscatter is read only with brdf: Ggx (this node has Charlie)"), "{e}");
        assert!(e.contains("\"lut\""), "{e}");
    }
}
