//! Built-in procedural lat-long environment maps, so that every graph, test and demo runs with no
//! data files at all.
//!
//! All maps are 3-channel f32, deterministic (pure functions of the name), and use hdrflow's
//! lat-long convention (`crate::geometry::latlong`: +Y up, row 0 = zenith, centre column = forward
//! -Z): every texel's value is a function of its centre direction `texel_direction(x, y, w, h)`.
//! They are rendered in parallel over rows (rayon) and take a few milliseconds each.
//!
//! | name         | size    | what it is for |
//! |--------------|---------|----------------|
//! | `sky`        | 512x256 | a realistic hard case: sky gradient, ground, a 2-degree sun of ~45000 carrying ~97% of the energy, > 16 stops of range |
//! | `constant`   | 64x32   | closed form: diffuse albedo a under constant L gives a * L on the whole sphere |
//! | `hemisphere` | 64x32   | closed form: 1 above the horizon, 0 below: a diffuse surface with normal n gets a (1 + n_y) / 2 (in the limit of fine texels) |
//! | `linear`     | 128x64  | closed form: L(d) = a + b.d, a = 1, b = (0.3, 0.5, 0.2): irradiance pi a + (2 pi / 3) b.n |
//! | `studio`     | 512x256 | several bright sources: dark 0.02 background, two softboxes (100 and 40), one tiny 2000 spot |
//!
//! The closed forms are in `../shared/NOTES.md`, "Closed forms for tests". Note that the maps are
//! piecewise constant per texel, so "closed form" holds up to the discretisation (e.g. the
//! `hemisphere` horizon falls exactly between rows H/2 - 1 and H/2, so that map is exact).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::latlong;
use crate::values::Image;

/// (name, one-line description) of every built-in map, in a stable order.
pub const BUILTINS: &[(&str, &str)] = &[
    ("sky", "512x256 clear sky with ground and a 2-degree sun at 35 deg elevation (~45000, >16 stops, sun ~97% of the energy)"),
    ("constant", "64x32 constant radiance 1 (closed form: diffuse albedo a gives a everywhere)"),
    ("hemisphere", "64x32 radiance 1 above the horizon, 0 below (closed form: a (1 + n_y) / 2)"),
    ("linear", "128x64 radiance 1 + (0.3, 0.5, 0.2).d (closed form: irradiance pi + (2 pi / 3) b.n)"),
    ("studio", "512x256 dark studio (0.02) with two softboxes (100, 40) and a tiny 2000 spot"),
];

/// The built-in map called `name`, or `None` for an unknown name (see [`BUILTINS`]).
/// The size of a built-in map, without rendering it.
pub fn builtin_size(name: &str) -> Option<(usize, usize)> {
    match name {
        "sky" | "studio" => Some((512, 256)),
        "constant" | "hemisphere" => Some((64, 32)),
        "linear" => Some((128, 64)),
        _ => None,
    }
}

pub fn builtin(name: &str) -> Option<Image> {
    match name {
        "sky" => Some(sky()),
        "constant" => Some(render(64, 32, |_| [1.0, 1.0, 1.0])),
        "hemisphere" => Some(render(64, 32, |d| if d[1] > 0.0 { [1.0; 3] } else { [0.0; 3] })),
        "linear" => Some(render(128, 64, |d| {
            let v = LINEAR_A + LINEAR_B[0] * d[0] + LINEAR_B[1] * d[1] + LINEAR_B[2] * d[2];
            [v, v, v]
        })),
        "studio" => Some(studio()),
        _ => None,
    }
}

/// `linear`: constant term a.
pub const LINEAR_A: f64 = 1.0;
/// `linear`: gradient b (|b| = 0.62 < a, so the map is positive everywhere).
pub const LINEAR_B: [f64; 3] = [0.3, 0.5, 0.2];

/// `sky`: sun radiance (RGB), angular radius and direction (elevation, azimuth phi).
pub const SKY_SUN_RADIANCE: [f64; 3] = [50000.0, 45000.0, 38000.0];
pub const SKY_SUN_RADIUS_DEG: f64 = 2.0;
pub const SKY_SUN_ELEVATION_DEG: f64 = 35.0;
/// phi = 0.6 pi: between left (-X, pi/2) and forward (-Z, pi), i.e. front-left.
pub const SKY_SUN_PHI: f64 = 0.6 * PI;

/// Renders a W x H map from a function of the texel-centre direction, rows in parallel.
fn render<F>(w: usize, h: usize, f: F) -> Image
where
    F: Fn([f64; 3]) -> [f64; 3] + Sync,
{
    let mut data = vec![0f32; w * h * 3];
    data.par_chunks_mut(w * 3).enumerate().for_each(|(y, row)| {
        for (x, px) in row.chunks_exact_mut(3).enumerate() {
            let v = f(latlong::texel_direction(x, y, w, h));
            px[0] = v[0] as f32;
            px[1] = v[1] as f32;
            px[2] = v[2] as f32;
        }
    });
    Image::from_vec(w, h, 3, data)
}

/// Coverage in [0, 1] of a disc of angular radius `radius` centred on `centre`, seen from the
/// texel-centre direction `d`, with a linear ramp one texel (`texel` radians) wide across the rim:
/// an anti-aliased edge, so that the disc's total energy varies smoothly with its radius and no
/// single texel carries it alone.
#[inline]
fn disc_coverage(d: DVec3, centre: DVec3, radius: f64, texel: f64) -> f64 {
    let half = 0.5 * texel;
    let c = d.dot(centre);
    if c < (radius + half).cos() {
        return 0.0;
    }
    let angle = c.clamp(-1.0, 1.0).acos();
    ((radius + half - angle) / texel).clamp(0.0, 1.0)
}

/// `sky` 512x256: sky gradient, ground, a small bright sun (see the module table).
fn sky() -> Image {
    let (w, h) = (512usize, 256usize);
    let sun = DVec3::from(latlong::direction((90.0 - SKY_SUN_ELEVATION_DEG).to_radians(), SKY_SUN_PHI));
    let radius = SKY_SUN_RADIUS_DEG.to_radians();
    let texel = PI / h as f64;
    let zenith = [0.2, 0.35, 0.8];
    let horizon = [0.8, 0.85, 0.9];
    let ground = [0.14, 0.15, 0.08];
    render(w, h, move |d| {
        let mut v = if d[1] > 0.0 {
            // sqrt: the sky stays pale near the horizon and deepens towards the zenith.
            let t = d[1].sqrt();
            // A soft aureole around the sun (e-folding ~8.6 degrees; the chord length stands in
            // for the angle, which is all that matters where the glow is visible).
            let chord = (2.0 * (1.0 - DVec3::from(d).dot(sun))).max(0.0).sqrt();
            let glow = 2.0 * (-chord / 0.15).exp();
            [
                horizon[0] + (zenith[0] - horizon[0]) * t + glow,
                horizon[1] + (zenith[1] - horizon[1]) * t + glow,
                horizon[2] + (zenith[2] - horizon[2]) * t + 0.8 * glow,
            ]
        } else {
            // Smooth low-frequency variation in [0.7, 1.0] (a "landscape"), never 0.
            let k = 0.85 + 0.1 * (3.0 * d[0]).sin() * (2.0 * d[2]).cos() + 0.05 * (5.0 * d[2] + 1.0).sin();
            [ground[0] * k, ground[1] * k, ground[2] * k]
        };
        let s = disc_coverage(DVec3::from(d), sun, radius, texel);
        if s > 0.0 {
            for k in 0..3 {
                v[k] = v[k] * (1.0 - s) + SKY_SUN_RADIANCE[k] * s;
            }
        }
        v
    })
}

/// `studio` 512x256: a dark room with two rectangular softboxes and a tiny spot.
fn studio() -> Image {
    let (w, h) = (512usize, 256usize);
    let texel = PI / h as f64;
    // Softboxes: (elevation centre, phi centre, half-height, half-width (angular, along the
    // horizontal great circle), radiance).
    let boxes: [(f64, f64, f64, f64, [f64; 3]); 2] = [
        (30f64.to_radians(), 0.8 * PI, 6f64.to_radians(), 10f64.to_radians(), [100.0, 98.0, 95.0]),
        (15f64.to_radians(), 1.35 * PI, 10f64.to_radians(), 7f64.to_radians(), [40.0, 40.0, 42.0]),
    ];
    let spot = DVec3::from(latlong::direction((90.0f64 - 50.0).to_radians(), 1.1 * PI));
    let spot_radius = 1f64.to_radians();
    let spot_radiance = [2000.0, 1950.0, 1850.0];
    render(w, h, move |d| {
        let mut v = [0.02; 3];
        let (theta, phi) = latlong::angles(d);
        let elevation = 0.5 * PI - theta;
        for &(el, ph, hh, hw, l) in &boxes {
            let mut dphi = (phi - ph).rem_euclid(2.0 * PI);
            if dphi > PI {
                dphi -= 2.0 * PI;
            }
            if (elevation - el).abs() <= hh && dphi.abs() * el.cos() <= hw {
                v = l;
            }
        }
        let s = disc_coverage(DVec3::from(d), spot, spot_radius, texel);
        if s > 0.0 {
            for k in 0..3 {
                v[k] = v[k] * (1.0 - s) + spot_radiance[k] * s;
            }
        }
        v
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::colour::rec709_luminance as luminance;

    #[test]
    fn all_builtins_exist_with_sizes_and_sane_values() {
        let sizes = [
            ("sky", 512, 256),
            ("constant", 64, 32),
            ("hemisphere", 64, 32),
            ("linear", 128, 64),
            ("studio", 512, 256),
        ];
        assert_eq!(BUILTINS.len(), sizes.len());
        for (name, w, h) in sizes {
            assert!(BUILTINS.iter().any(|(n, _)| *n == name));
            let img = builtin(name).unwrap();
            assert_eq!((img.width, img.height, img.channels, img.data.len()), (w, h, 3, w * h * 3), "{name}");
            assert_eq!(builtin_size(name), Some((w, h)), "{name}: builtin_size agrees with the render");
            assert!(img.data.iter().all(|v| v.is_finite() && *v >= 0.0), "{name}");
            assert_eq!(builtin(name).unwrap(), img, "{name} is not deterministic");
        }
        assert!(builtin("nope").is_none());
    }

    #[test]
    fn constant_and_hemisphere() {
        assert!(builtin("constant").unwrap().data.iter().all(|&v| v == 1.0));
        let hemi = builtin("hemisphere").unwrap();
        for y in 0..32 {
            for x in 0..64 {
                let want = if y < 16 { 1.0 } else { 0.0 };
                assert_eq!(hemi.rgb(x, y), [want; 3], "({x},{y})");
            }
        }
    }

    #[test]
    fn linear_matches_formula_and_is_positive() {
        let img = builtin("linear").unwrap();
        for y in 0..img.height {
            for x in 0..img.width {
                let d = latlong::texel_direction(x, y, img.width, img.height);
                let want = 1.0 + 0.3 * d[0] + 0.5 * d[1] + 0.2 * d[2];
                let p = img.rgb(x, y);
                assert!((p[0] as f64 - want).abs() < 1e-6 && p[0] == p[1] && p[1] == p[2]);
                assert!(p[0] > 0.3);
            }
        }
    }

    #[test]
    fn sky_dynamic_range_and_sun_share() {
        let img = builtin("sky").unwrap();
        let (w, h) = (img.width, img.height);
        let (mut max_l, mut min_l) = (0.0f64, f64::MAX);
        let (mut total, mut sun, mut sun_texels) = (0.0f64, 0.0f64, 0usize);
        for y in 0..h {
            let sa = latlong::texel_solid_angle(y, w, h);
            for x in 0..w {
                let l = luminance(img.rgb(x, y));
                max_l = max_l.max(l);
                if l > 0.0 {
                    min_l = min_l.min(l);
                }
                total += l * sa;
                if l > 1000.0 {
                    sun += l * sa;
                    sun_texels += 1;
                }
            }
        }
        let stops = (max_l / min_l).log2();
        assert!(stops >= 16.0, "only {stops} stops");
        assert!(sun / total > 0.5, "sun share {}", sun / total);
        assert!(sun_texels >= 8, "sun covers only {sun_texels} texels");
        // The sun is where it was put: front-left, 35 degrees up.
        let (mut best, mut at) = (0.0, (0, 0));
        for y in 0..h {
            for x in 0..w {
                let l = luminance(img.rgb(x, y));
                if l > best {
                    best = l;
                    at = (x, y);
                }
            }
        }
        let d = latlong::texel_direction(at.0, at.1, w, h);
        // (Every texel fully inside the disc ties at the sun radiance; the first found is on its
        // upper rim, up to ~1.7 degrees from the centre.)
        assert!((d[1].asin().to_degrees() - 35.0).abs() < 2.5, "sun at {d:?}");
        assert!(d[0] < 0.0 && d[2] < 0.0, "sun not front-left: {d:?}");
        // Sky ~1 and ground ~0.1-0.2.
        let zenith = luminance(img.rgb(0, 0));
        let nadir = luminance(img.rgb(0, h - 1));
        assert!((0.2..1.2).contains(&zenith), "{zenith}");
        assert!((0.05..0.25).contains(&nadir), "{nadir}");
    }

    #[test]
    fn studio_has_its_sources() {
        let img = builtin("studio").unwrap();
        let lum: Vec<f64> = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .map(|(x, y)| luminance(img.rgb(x, y)))
            .collect();
        let count = |lo: f64, hi: f64| lum.iter().filter(|&&l| l >= lo && l < hi).count();
        assert!(count(0.019, 0.021) > lum.len() / 2, "background");
        assert!(count(90.0, 110.0) > 50, "key softbox");
        assert!(count(35.0, 45.0) > 50, "fill softbox");
        let max = lum.iter().cloned().fold(0.0, f64::max);
        assert!((1500.0..2100.0).contains(&max), "spot {max}");
        assert!(count(200.0, 1e9) >= 2, "spot should cover a few texels");
    }
}
