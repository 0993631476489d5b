//! Parametric lights out of an environment map: the few brightest connected regions, each a
//! [`Light`], plus an ambient colour, with the map's integral conserved exactly, channel by
//! channel (the "lights + ambient" model of lighting-estimation papers, e.g. Gardner et al.,
//! *Deep Parametric Indoor Lighting Estimation*, ICCV 2019).
//!
//! For a W x H lat-long map with texel radiance `L_t` (RGB: the first three channels; a map of
//! fewer channels is grey, its first channel), Rec. 709 luminance `Y_t`, midpoint solid angle
//! `dOmega_t` ([`latlong::texel_solid_angle`]) and integral `I_c = sum_t L_t,c dOmega_t`:
//!
//! 1. **Level and threshold**, exactly as `SunExtract` ([`sun::level`]): `m` = the median texel
//!    luminance (or the solid-angle-weighted mean when the median is not positive), threshold
//!    `t = m 2^threshold_stops`.
//! 2. **Regions.** The connected components of the texels with `Y > t` (strictly), with
//!    `SunExtract`'s connectivity ([`sun::neighbours`]: 8-connected, wrapping across the seam
//!    x = 0 / W, and across each pole to the three texels facing it). The region `S` has solid
//!    angle `Omega_S = sum_S dOmega`, integral `E_S,c = sum_S L_c dOmega`, mean radiance
//!    `M_S,c = E_S,c / Omega_S` and energy `sum_S Y dOmega` (its luminance integral). The
//!    `max_lights` regions of largest energy are kept (ties: the region whose first texel in
//!    row-major order comes first), most energetic first.
//! 3. **Ambient and radiance** (per channel c; K = the kept regions). The model is an ambient
//!    radiance `A_c` over the whole sphere (4 pi sr) plus, in each light's region, the light's
//!    radiance on top: `r_S,c = max(M_S,c - A_c, 0)`. Conservation demands
//!    `sum_S r_S,c Omega_S + 4 pi A_c = I_c`. With `K_c` = the lights whose mean exceeds the
//!    ambient (`M_S,c > A_c`), that is
//!    `A_c = (I_c - sum_{K_c} E_S,c) / (4 pi - sum_{K_c} Omega_S)`: the mean radiance of
//!    everything but those lights, over the rest of the sphere. It is solved by starting from
//!    `K_c = K` and dropping the lights with `M_S,c <= A_c` until none is dropped; each drop can
//!    only lower `A_c` (a weighted mean of the old `A_c` and a value at most `A_c`), so the
//!    lights kept stay above it and at most |K| rounds are needed. (Were `sum Omega_S` ever to
//!    reach 4 pi, the least energetic lights would be left out until it does not; a region is
//!    at most the texels above the median, so this cannot happen on a real grid.)
//! 4. **Light.** `direction` = the normalised luminance-weighted centroid `sum_S Y dOmega d`
//!    (the region's brightest texel if that sum vanishes); `solid_angle = Omega_S`;
//!    `radiance = r_S`. A channel's radiance is 0 when the region's mean is not above the
//!    ambient (a red light in blue surroundings has no blue).
//! 5. **Residual.** The map with the colour channels of each light's texels set to
//!    `F_S,c = M_S,c - r_S,c` (= `A_c`, or the region's own mean where the light was clamped),
//!    rounded to f32; alpha and other channels kept; regions above the threshold beyond
//!    `max_lights` are left as they are (they are part of the ambient).
//!
//! **Conservation.** `sum_S r_S,c Omega_S + 4 pi A_c = I_c` by construction (f64; relative
//! ~1e-15 on non-negative maps; the tests check 1e-12 and the brief's 1e-4). The residual also
//! conserves: `integral(residual) + sum_S r_S,c Omega_S = I_c - sum_S E_S,c + sum_S F_S,c
//! Omega_S + sum_S r_S,c Omega_S = I_c`, up to the f32 rounding of `F` (the tests check 1e-6).
//! The ambient is the rest's mean over `4 pi - sum Omega_S` sr, while the grid's total solid
//! angle is `4 pi (x / sin x)`, `x = pi / 2H` (the midpoint rule, `pi^2 / 24 H^2` relative
//! above 4 pi), so the residual's mean over the grid equals `A` to that relative order.
//!
//! No region (a uniform or black map, a threshold above every texel): no lights, `A = I / 4 pi`,
//! the residual is the input.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{latlong, unit};
use crate::maths::fit::sun::{colour_channels, level, luminances, luminous_integral, neighbours};
use crate::values::{Image, Light, Lights};

/// What [`extract_lights`] found, with the quantities of the module documentation.
#[derive(Clone, Debug)]
pub struct LightExtraction {
    pub lights: Lights,
    /// The input with the lights' texels filled (step 5).
    pub residual: Image,
    /// The level `m`.
    pub level: f64,
    /// The threshold `t = m 2^threshold_stops`.
    pub threshold: f64,
    /// How many regions were above the threshold (kept or not).
    pub regions: usize,
    /// The number of texels of each light, in the lights' order.
    pub texels: Vec<usize>,
}

/// One connected region above the threshold.
#[derive(Clone, Debug)]
struct Region {
    id: u32,
    texels: usize,
    brightest: usize,
    omega: f64,
    energy: f64,
    sum: [f64; 3],
    centroid: DVec3,
}

/// `sum_t L_t,c dOmega_t` per channel (rows summed in parallel, then in order: deterministic).
pub fn integral(env: &Image) -> [f64; 3] {
    let (w, h) = (env.width, env.height);
    let rows: Vec<[f64; 3]> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut s = [0.0f64; 3];
            for x in 0..w {
                for (sc, v) in s.iter_mut().zip(env.rgb(x, y)) {
                    *sc += v as f64;
                }
            }
            s.map(|v| v * latlong::texel_solid_angle(y, w, h))
        })
        .collect();
    rows.iter().fold([0.0; 3], |a, r| [a[0] + r[0], a[1] + r[1], a[2] + r[2]])
}

/// The connected regions of texels with `lum > threshold`: the label of every texel (0: none,
/// else the region's id, 1-based in row-major order of the regions' first texels) and the
/// regions' sums.
fn regions(env: &Image, lum: &[f64], threshold: f64) -> (Vec<u32>, Vec<Region>) {
    let (w, h) = (env.width, env.height);
    let mut label = vec![0u32; w * h];
    let mut found = Vec::new();
    let mut stack = Vec::new();
    let mut nb = [(0usize, 0usize); 11];
    for start in 0..w * h {
        if label[start] != 0 || !(lum[start] > threshold) {
            continue;
        }
        let id = found.len() as u32 + 1;
        let mut r =
            Region { id, texels: 0, brightest: start, omega: 0.0, energy: 0.0, sum: [0.0; 3], centroid: DVec3::ZERO };
        label[start] = id;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let d_omega = latlong::texel_solid_angle(y, w, h);
            r.texels += 1;
            r.omega += d_omega;
            r.energy += lum[i] * d_omega;
            for (sc, v) in r.sum.iter_mut().zip(env.rgb(x, y)) {
                *sc += v as f64 * d_omega;
            }
            r.centroid += lum[i] * d_omega * DVec3::from(latlong::texel_direction(x, y, w, h));
            if lum[i] > lum[r.brightest] || (lum[i] == lum[r.brightest] && i < r.brightest) {
                r.brightest = i;
            }
            let k = neighbours(x, y, w, h, &mut nb);
            for &(nx, ny) in &nb[..k] {
                let j = ny * w + nx;
                if label[j] == 0 && lum[j] > threshold {
                    label[j] = id;
                    stack.push(j);
                }
            }
        }
        found.push(r);
    }
    (label, found)
}

/// The ambient of channel `c` and which lights stay above it (step 3).
fn solve_ambient(total: f64, lights: &[&Region], c: usize) -> (f64, Vec<bool>) {
    let mut above = vec![true; lights.len()];
    loop {
        let (mut e, mut omega) = (0.0f64, 0.0f64);
        for (r, _) in lights.iter().zip(&above).filter(|(_, a)| **a) {
            e += r.sum[c];
            omega += r.omega;
        }
        let ambient = (total - e) / (4.0 * PI - omega);
        let mut dropped = false;
        for (r, a) in lights.iter().zip(above.iter_mut()) {
            if *a && !(r.sum[c] / r.omega > ambient) {
                *a = false;
                dropped = true;
            }
        }
        if !dropped {
            return (ambient, above);
        }
    }
}

/// Extracts up to `max_lights` lights and the ambient of `env` (see the module documentation).
/// `env` should be finite (the operator checks); `threshold_stops` is any finite number. Never
/// NaN for finite input.
pub fn extract_lights(env: &Image, max_lights: usize, threshold_stops: f64) -> LightExtraction {
    let (w, h) = (env.width, env.height);
    let total = integral(env);
    let none = |level: f64, threshold: f64, regions: usize| LightExtraction {
        lights: Lights { lights: Vec::new(), ambient: total.map(|v| v / (4.0 * PI)) },
        residual: env.clone(),
        level,
        threshold,
        regions,
        texels: Vec::new(),
    };
    if w == 0 || h == 0 || env.channels == 0 {
        return none(0.0, 0.0, 0);
    }
    let lum = luminances(env);
    let level = level(&lum, w, h, luminous_integral(&lum, w, h));
    let threshold = level * 2f64.powf(threshold_stops);
    if !(level > 0.0) || !threshold.is_finite() {
        return none(level.max(0.0), threshold.max(0.0), 0);
    }
    let (label, found) = regions(env, &lum, threshold);
    let mut order: Vec<&Region> = found.iter().collect();
    order.sort_by(|a, b| b.energy.total_cmp(&a.energy).then(a.id.cmp(&b.id)));
    order.truncate(max_lights);
    // Never let the lights cover the whole sphere's 4 pi (see step 3).
    while !order.is_empty() && !(order.iter().map(|r| r.omega).sum::<f64>() < 4.0 * PI * (1.0 - 1e-9)) {
        order.pop();
    }
    if order.is_empty() {
        return none(level, threshold, found.len());
    }

    let mut ambient = [0.0f64; 3];
    let mut radiance = vec![[0.0f64; 3]; order.len()];
    for (c, a) in ambient.iter_mut().enumerate() {
        let (value, above) = solve_ambient(total[c], &order, c);
        *a = value;
        for ((rad, r), up) in radiance.iter_mut().zip(&order).zip(above) {
            rad[c] = if up { (r.sum[c] / r.omega - value).max(0.0) } else { 0.0 };
        }
    }

    // The residual: each light's texels filled with F = M - r (rounded to f32).
    let cc = colour_channels(env);
    let mut fill_of = vec![None; found.len() + 1];
    for (r, rad) in order.iter().zip(&radiance) {
        let fill: [f32; 3] = std::array::from_fn(|c| (r.sum[c] / r.omega - rad[c]) as f32);
        fill_of[r.id as usize] = Some(fill);
    }
    let mut residual = env.clone();
    let ch = env.channels;
    residual.data.par_chunks_exact_mut(ch).zip(label.par_iter()).for_each(|(px, &id)| {
        if let Some(Some(fill)) = fill_of.get(id as usize) {
            px[..cc].copy_from_slice(&fill[..cc]);
        }
    });

    let lights = order
        .iter()
        .zip(&radiance)
        .map(|(r, rad)| {
            let brightest = latlong::texel_direction(r.brightest % w, r.brightest / w, w, h);
            Light {
                direction: unit(r.centroid).map(|d| d.to_array()).unwrap_or(brightest),
                solid_angle: r.omega,
                radiance: *rad,
            }
        })
        .collect();
    LightExtraction {
        lights: Lights { lights, ambient },
        residual,
        level,
        threshold,
        regions: found.len(),
        texels: order.iter().map(|r| r.texels).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Worst relative error over the channels of `a` against `b`.
    fn rel(a: [f64; 3], b: [f64; 3]) -> f64 {
        (0..3).map(|c| (a[c] - b[c]).abs() / b[c].abs().max(f64::MIN_POSITIVE)).fold(0.0, f64::max)
    }

    /// The model's identity and the residual's, worst relative errors.
    fn conservation(env: &Image, e: &LightExtraction) -> (f64, f64) {
        let total = integral(env);
        let lights: Vec<[f64; 3]> = e.lights.lights.iter().map(Light::power).collect();
        let with_residual = (0..3).map(|c| integral(&e.residual)[c] + lights.iter().map(|p| p[c]).sum::<f64>());
        let with_residual: Vec<f64> = with_residual.collect();
        (rel(e.lights.power(), total), rel([with_residual[0], with_residual[1], with_residual[2]], total))
    }

    /// A sky of radiance `sky` with discs (centre, angular radius in radians, radiance).
    fn sky_with_discs(w: usize, h: usize, sky: [f32; 3], discs: &[([f64; 3], f64, [f32; 3])]) -> Image {
        Image::from_fn_rgb(w, h, |x, y| {
            let d = DVec3::from(latlong::texel_direction(x, y, w, h));
            for (centre, radius, l) in discs {
                if d.dot(DVec3::from(*centre).normalize()) > radius.cos() {
                    return *l;
                }
            }
            sky
        })
    }

    fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
        DVec3::from(a).angle_between(DVec3::from(b).normalize()).to_degrees()
    }

    #[test]
    fn zero_one_three_and_five_blobs() {
        let (w, h) = (256, 128);
        let sky = [0.5f32, 0.6, 0.8];
        // Five discs of decreasing energy: one on the seam (phi = 0), one around the north
        // pole, three elsewhere; radiance 1000, 800, ... so energies are distinct.
        let discs: Vec<([f64; 3], f64, [f32; 3])> = vec![
            (latlong::direction_deg(70.0, 0.0), 8f64.to_radians(), [1000.0, 900.0, 800.0]),
            ([0.0, 1.0, 0.0], 7f64.to_radians(), [900.0, 900.0, 900.0]),
            (latlong::direction_deg(100.0, 120.0), 6f64.to_radians(), [800.0, 500.0, 300.0]),
            (latlong::direction_deg(60.0, 220.0), 5f64.to_radians(), [700.0, 700.0, 700.0]),
            (latlong::direction_deg(130.0, 300.0), 4f64.to_radians(), [600.0, 650.0, 700.0]),
        ];
        for n in [0usize, 1, 3, 5] {
            let env = sky_with_discs(w, h, sky, &discs[..n]);
            let e = extract_lights(&env, 8, 6.0);
            assert_eq!(e.lights.lights.len(), n, "{n} blobs");
            assert_eq!(e.regions, n);
            let (model, residual) = conservation(&env, &e);
            assert!(model < 1e-12 && residual < 1e-6, "{n} blobs: {model:e}, {residual:e}");
            for (k, (l, (centre, _, radiance))) in e.lights.lights.iter().zip(&discs).enumerate() {
                let lit = env.data.chunks(3).filter(|p| *p == radiance).count();
                assert_eq!(e.texels[k], lit, "blob {k}: one region, seam and pole included");
                assert!(angle_deg(l.direction, *centre) < 0.5, "blob {k}: {:?}", l.direction);
                // r = M - A (every texel of a disc has the same value), A = the rest's mean.
                for ((got, value), ambient) in l.radiance.iter().zip(radiance).zip(e.lights.ambient) {
                    let want = *value as f64 - ambient;
                    assert!((got - want).abs() < 1e-9 * want, "blob {k}: {:?}", l.radiance);
                }
            }
            // The ambient is the sky's radiance over 4 pi - sum Omega, up to the grid's
            // 4 pi (x / sin x) total solid angle: relative pi^2 / (24 H^2) = 2.5e-5.
            let x = PI / (2.0 * h as f64);
            for (ambient, s) in e.lights.ambient.iter().zip(sky) {
                let a = ambient / s as f64;
                assert!((a - 1.0).abs() < 1.5 * (x / x.sin() - 1.0) + 1e-12, "{n}: ambient {a}");
            }
            // The residual is the sky within f32 rounding of the ambient.
            assert!(e.residual.data.chunks(3).all(|p| (0..3).all(|c| (p[c] / sky[c] - 1.0).abs() < 1e-4)));
        }
    }

    #[test]
    fn max_lights_keeps_the_most_energetic_and_the_rest_is_ambient() {
        let (w, h) = (128, 64);
        let discs = vec![
            (latlong::direction_deg(90.0, 40.0), 5f64.to_radians(), [100.0f32; 3]),
            (latlong::direction_deg(90.0, 160.0), 10f64.to_radians(), [100.0; 3]), // 4x the area
            (latlong::direction_deg(50.0, 280.0), 5f64.to_radians(), [300.0; 3]),  // 3x the radiance
        ];
        let env = sky_with_discs(w, h, [1.0; 3], &discs);
        let e = extract_lights(&env, 2, 4.0);
        assert_eq!((e.regions, e.lights.lights.len()), (3, 2));
        // Within a third of a texel (2.8 degrees): the discs' texel sets are not symmetric.
        assert!(angle_deg(e.lights.lights[0].direction, discs[1].0) < 1.0, "{:?}", e.lights);
        assert!(angle_deg(e.lights.lights[1].direction, discs[2].0) < 1.0, "{:?}", e.lights);
        let (model, residual) = conservation(&env, &e);
        assert!(model < 1e-12 && residual < 1e-6, "{model:e} {residual:e}");
        // The third disc stays in the residual, and raises the ambient above the sky.
        assert!(e.residual.data.chunks(3).any(|p| p[0] == 100.0));
        assert!(e.lights.ambient[0] > 1.01);
        // max_lights = 1: the largest.
        let one = extract_lights(&env, 1, 4.0);
        assert_eq!(one.lights.lights.len(), 1);
        assert!(angle_deg(one.lights.lights[0].direction, discs[1].0) < 1.0);
        assert!(conservation(&env, &one).0 < 1e-12);
    }

    #[test]
    fn a_light_below_the_ambient_in_one_channel_is_clamped_and_still_conserves() {
        // A red light in a strongly blue sky: its blue is below the ambient's.
        let (w, h) = (64, 32);
        let discs = vec![(latlong::direction_deg(60.0, 90.0), 12f64.to_radians(), [400.0f32, 5.0, 0.5])];
        let env = sky_with_discs(w, h, [0.1, 0.1, 3.0], &discs);
        let e = extract_lights(&env, 4, 2.0);
        assert_eq!(e.lights.lights.len(), 1);
        let l = &e.lights.lights[0];
        assert_eq!(l.radiance[2], 0.0, "{:?}", l.radiance);
        assert!(l.radiance[0] > 300.0 && l.radiance[1] > 4.0);
        // Blue: no light, so the ambient is the whole map's mean over 4 pi; the region keeps
        // its own blue in the residual.
        assert!((e.lights.ambient[2] - integral(&env)[2] / (4.0 * PI)).abs() < 1e-12);
        assert!(e.residual.data.chunks(3).any(|p| p[2] == 0.5));
        let (model, residual) = conservation(&env, &e);
        assert!(model < 1e-12 && residual < 1e-6, "{model:e} {residual:e}");
        assert!(l.radiance.iter().chain(&e.lights.ambient).all(|v| v.is_finite() && *v >= 0.0));
    }

    #[test]
    fn no_region_uniform_black_and_alpha() {
        for env in [Image::from_fn_rgb(32, 16, |_, _| [2.0, 1.0, 0.5]), Image::new(32, 16, 3)] {
            let e = extract_lights(&env, 5, 3.0);
            assert!(e.lights.lights.is_empty());
            assert_eq!(e.residual, env);
            assert!(rel(e.lights.power(), integral(&env)) < 1e-12 || integral(&env) == [0.0; 3]);
            assert!(e.lights.ambient.iter().all(|v| v.is_finite()));
        }
        // Grey + alpha: the fill goes into the grey channel only.
        let (w, h) = (32, 16);
        let mut data = Vec::new();
        for i in 0..w * h {
            data.extend_from_slice(&[if i == 5 * w + 7 || i == 9 * w + 20 { 500.0 } else { 2.0 }, 0.25]);
        }
        let env = Image::with_names(w, h, vec!["Y".into(), "A".into()], data);
        let e = extract_lights(&env, 5, 3.0);
        assert_eq!(e.texels, [1, 1]);
        // The fill is the ambient: 2 up to the grid's excess solid angle, pi^2 / (24 H^2) = 1.6e-3.
        assert!(e.residual.data.chunks(2).all(|p| p[1] == 0.25 && (p[0] / 2.0 - 1.0).abs() < 2e-3), "{:?}", e.lights);
        let (model, residual) = conservation(&env, &e);
        assert!(model < 1e-12 && residual < 1e-6);
    }

    #[test]
    fn builtin_sky_and_studio_conserve() {
        for name in ["sky", "studio"] {
            let env = crate::formats::builtin::builtin(name).unwrap();
            let e = extract_lights(&env, 5, 8.0);
            let (model, residual) = conservation(&env, &e);
            assert!(model < 1e-12 && residual < 1e-6, "{name}: {model:e} {residual:e}");
            assert!(!e.lights.lights.is_empty(), "{name}");
        }
        // The sky's sun agrees with SunExtract's direction.
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let e = extract_lights(&sky, 1, 8.0);
        let s = crate::maths::fit::sun::extract_sun(&sky, 8.0);
        assert_eq!(e.texels[0], s.texels);
        assert!(angle_deg(e.lights.lights[0].direction, s.light.direction) < 0.05);
    }
}
