//! The deliberate mistakes tests/filament_render.rs must catch that are edits of the files (those
//! a bake can make through hdrflow's options are made with `--set` there; the mirrored map is
//! `common/markers.rs`'s `mirror_x`).

use hdrflow::maths::ibl::sh::project;
use hdrflow::values::{Image, ShFrame};

/// `sh.txt` in cmgen's layout (9 lines `( r, g, b); // name`) holding `coeffs`.
pub fn sh_text(coeffs: &[[f64; 3]]) -> String {
    let names = ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"];
    coeffs
        .iter()
        .zip(names)
        .map(|(c, n)| format!("({:>18.15}, {:>18.15}, {:>18.15}); // {n}\n", c[0], c[1], c[2]))
        .collect()
}

/// The mistake "SH not pre-scaled": the map's orthonormal radiance coefficients `L_lm` (world
/// frame) written where Filament expects `(A_l / pi) k_lm L_lm`.
pub fn unscaled_sh_text(env: &Image) -> String {
    sh_text(&project(env, 2, ShFrame::World))
}
