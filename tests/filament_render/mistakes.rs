//! The deliberate mistakes tests/filament_render.rs must catch (those a bake can make through
//! hdrflow's options are made with `--set` there), and the orientation map with its markers.

use glam::DVec3;
use hdrflow::maths::sh::project;
use hdrflow::values::{Image, ShFrame};

/// The lat-long map mirrored left to right, `L'(x, y, z) = L(-x, y, z)`: phi -> 2 pi - phi, which
/// maps column x to column `W - 1 - x` exactly: what `cmgen --no-mirror` shows, or a cube written
/// for a left-handed lookup.
pub fn mirror_x(env: &Image) -> Image {
    let (w, h, c) = (env.width, env.height, env.channels);
    let mut out = env.clone();
    for y in 0..h {
        for x in 0..w {
            let src = w - 1 - x;
            out.data[(y * w + x) * c..(y * w + x + 1) * c]
                .copy_from_slice(&env.data[(y * w + src) * c..(y * w + src + 1) * c]);
        }
    }
    out
}

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

/// A marker: its colour and direction (hdrflow's axes).
pub struct Marker {
    pub name: &'static str,
    pub colour: [f32; 3],
    pub direction: DVec3,
}

/// The markers of [`orientation_map`]: red at the map's centre (forward, -Z), green 30 degrees
/// to its left (towards -X, a quarter of the width to the left in the image), blue 30 degrees to
/// its right (towards +X), white 30 degrees above.
pub fn markers() -> Vec<Marker> {
    let (s, c) = 30f64.to_radians().sin_cos();
    vec![
        Marker { name: "centre (red)", colour: [1.0, 0.0, 0.0], direction: DVec3::new(0.0, 0.0, -1.0) },
        Marker { name: "left (green)", colour: [0.0, 1.0, 0.0], direction: DVec3::new(-s, 0.0, -c) },
        Marker { name: "right (blue)", colour: [0.0, 0.0, 1.0], direction: DVec3::new(s, 0.0, -c) },
        Marker { name: "up (white)", colour: [1.0, 1.0, 1.0], direction: DVec3::new(0.0, s, -c) },
    ]
}

/// A dim grey 1024 x 512 map with the [`markers`] as spherical Gaussians of radiance 50 and
/// sharpness 3000 (about 1.5 degrees wide: several texels of a 256 cube face).
pub fn orientation_map() -> Image {
    let (w, h) = (1024, 512);
    let markers = markers();
    Image::from_fn_rgb(w, h, |x, y| {
        let d = DVec3::from(hdrflow::geometry::latlong::texel_direction(x, y, w, h));
        let mut px = [0.05f32; 3];
        for m in &markers {
            let g = 50.0 * (3000.0 * (m.direction.dot(d) - 1.0)).exp() as f32;
            for (p, c) in px.iter_mut().zip(m.colour) {
                *p += g * c;
            }
        }
        px
    })
}
