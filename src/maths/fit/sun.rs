//! Taking a sun out of an environment map: a [`Light`] plus a residual map, with the map's
//! integral conserved exactly, channel by channel.
//!
//! For a W x H lat-long map with texel radiance `L_i` (RGB: the first three channels; a map of
//! fewer channels is grey, its first channel), luminance `Y_i = 0.2126 R + 0.7152 G + 0.0722 B`
//! (Rec. 709, [`crate::colour::REC709`]) and midpoint solid angle `dOmega_i`
//! ([`latlong::texel_solid_angle`], the measure of every integral in hdrflow, so "integral"
//! below means `sum_i L_i dOmega_i`):
//!
//! 1. **Level.** `m` = the median of the texels' luminances (each texel counted once; the
//!    element of rank `floor(W H / 2)` in increasing order, rounded to f32), or, when that is 0
//!    or less (a map more than half black), the mean luminance over the sphere
//!    `sum Y dOmega / sum dOmega`.
//!    Threshold `t = m 2^threshold_stops`.
//! 2. **Region.** The sun region `S` is the connected set of texels with `Y > t` (strictly)
//!    that contains the brightest texel (the first in row-major order among equals). Texels are
//!    8-connected; columns wrap around (phi is periodic) and, in the first and last rows, a texel
//!    also touches the three texels facing it across the pole (columns `x + W/2 - 1` to
//!    `x + W/2 + 1`, mod W). If the brightest texel is not above `t` (a uniform map, an all-black map, or a
//!    threshold above the sun), there is no sun: the light has zero radiance and solid angle
//!    (its direction is the brightest texel's) and the residual is the input.
//! 3. **Fill.** The ring `R` = the texels outside `S` that touch it (same connectivity). The
//!    fill colour is the solid-angle-weighted mean of the ring, `F_c = sum_R L_c dOmega /
//!    sum_R dOmega`, clamped per channel to at most the region's smallest value of that channel
//!    (`F_c <= min_S L_c`, so the light's radiance is never negative), and rounded to f32 (the
//!    residual's precision). An empty ring (S is the whole map) fills with 0. The residual is the
//!    input with every colour channel of the texels of `S` set to `F` (other channels, such as
//!    alpha, are kept).
//! 4. **Light.** `solid_angle = Omega_S = sum_S dOmega_i`;
//!    `radiance_c = (sum_S L_c dOmega - sum_S F_c dOmega) / Omega_S` (f64 sums of the f32
//!    values actually stored); `direction` = the normalised centroid of the texel directions
//!    weighted by the luminance removed, `sum_S (Y_i - Y(F)) dOmega_i d_i` (the brightest
//!    texel's direction if that sum vanishes).
//!
//! 5. **Rule.** [`extract_sun_by`] takes the region out only if it is a sun by
//!    [`super::sun_rule`] (small, carrying much of the light); [`extract_sun`] takes any region.
//!
//! **Conservation.** By construction, per channel, `integral(residual) + radiance_c Omega_S =
//! integral(input) - sum_S L_c dOmega + sum_S F_c dOmega + (sum_S L_c dOmega - sum_S F_c
//! dOmega) = integral(input)`, up to f64 rounding of sums of at most W H terms (relative
//! ~1e-12 for non-negative maps); the tests check 1e-4 relative on every shared real map and on
//! synthetic ones.

use glam::DVec3;
use rayon::prelude::*;

use super::sun_rule::{cone_radius_deg, Rejected, SunRule};
pub(crate) use crate::colour::rec709_luminance as luminance;
use crate::geometry::{latlong, unit};
use crate::values::{Image, Light};

/// What [`extract_sun`] found, with the quantities of the module documentation.
#[derive(Clone, Debug)]
pub struct SunExtraction {
    pub light: Light,
    /// The input with the sun's texels replaced by the fill colour.
    pub residual: Image,
    /// The reference level `m` (median luminance, or the mean when the median is not positive).
    pub level: f64,
    /// The threshold `t = m 2^threshold_stops`.
    pub threshold: f64,
    /// Number of texels in the region `S` (0: no sun).
    pub texels: usize,
    /// The fill colour `F` (zeros when there is no sun).
    pub fill: [f32; 3],
    /// The light's fraction of the map's luminous integral `sum Y dOmega` (0: no sun).
    pub share: f64,
    /// A region found above the threshold that the rule left in the map ([`super::sun_rule`]).
    pub rejected: Option<Rejected>,
}

/// The number of colour channels of `img`: 3 for RGB(A...), 1 for a grey map.
pub(crate) fn colour_channels(img: &Image) -> usize {
    if img.channels >= 3 {
        3
    } else {
        1
    }
}

/// The neighbours of texel (x, y) in the sun region's connectivity (see the module
/// documentation), written into `out`; returns how many.
pub(crate) fn neighbours(x: usize, y: usize, w: usize, h: usize, out: &mut [(usize, usize); 11]) -> usize {
    let mut n = 0;
    let mut push = |nx: usize, ny: usize, out: &mut [(usize, usize); 11]| {
        if (nx, ny) != (x, y) && !out[..n].contains(&(nx, ny)) {
            out[n] = (nx, ny);
            n += 1;
        }
    };
    for dy in -1i64..=1 {
        let ny = y as i64 + dy;
        if ny < 0 || ny >= h as i64 {
            continue;
        }
        for dx in -1i64..=1 {
            let nx = (x as i64 + dx).rem_euclid(w as i64) as usize;
            push(nx, ny as usize, out);
        }
    }
    if y == 0 || y + 1 == h {
        for dx in -1i64..=1 {
            let nx = (x as i64 + (w / 2) as i64 + dx).rem_euclid(w as i64) as usize;
            push(nx, y, out);
        }
    }
    n
}

/// Extracts the sun of `env` (see the module documentation), whatever the region's size and
/// share ([`SunRule::any`]). `env` should be finite (the operator checks); `threshold_stops` is
/// any finite number. Never NaN for finite input.
pub fn extract_sun(env: &Image, threshold_stops: f64) -> SunExtraction {
    extract_sun_by(env.clone(), &SunRule::any(threshold_stops))
}

/// [`extract_sun`] of a map the caller gives up: the residual is `env` itself with the sun's
/// texels filled, so a 16384 x 8192 map is not held twice (`SunExtract` takes its input when no
/// other node reads it).
pub fn extract_sun_in_place(env: Image, threshold_stops: f64) -> SunExtraction {
    extract_sun_by(env, &SunRule::any(threshold_stops))
}

/// The sun of `env` by `rule`: the region of steps 1 and 2 at `rule.threshold_stops`, taken out
/// (steps 3 and 4) only if [`SunRule::judge`] finds it a sun; else no light, the residual is
/// `env` untouched and [`SunExtraction::rejected`] says why. In place, as
/// [`extract_sun_in_place`].
pub fn extract_sun_by(env: Image, rule: &SunRule) -> SunExtraction {
    let threshold_stops = rule.threshold_stops;
    let (w, h) = (env.width, env.height);
    let none = |env: Image, direction: [f64; 3], level: f64, threshold: f64| SunExtraction {
        light: Light::none(direction),
        residual: env,
        level,
        threshold,
        texels: 0,
        fill: [0.0; 3],
        share: 0.0,
        rejected: None,
    };
    if w == 0 || h == 0 || env.channels == 0 {
        return none(env, [0.0, 1.0, 0.0], 0.0, 0.0);
    }

    // Luminance per texel (rows in parallel), the brightest texel and the level.
    let lum = luminances(&env);
    let brightest = lum.iter().enumerate().fold(0usize, |b, (i, &y)| if y > lum[b] { i } else { b });
    let brightest_dir = latlong::texel_direction(brightest % w, brightest / w, w, h);
    let total = luminous_integral(&lum, w, h);
    let level = level(&lum, w, h, total);
    let threshold = level * 2f64.powf(threshold_stops);
    if !(level > 0.0) || !(lum[brightest] > threshold) {
        return none(env, brightest_dir, level.max(0.0), threshold.max(0.0));
    }

    // Flood fill from the brightest texel: 1 = in S, 2 = in the ring R.
    let mut mark = vec![0u8; w * h];
    let mut stack = vec![brightest];
    mark[brightest] = 1;
    let mut region = Vec::new();
    let mut nb = [(0usize, 0usize); 11];
    while let Some(i) = stack.pop() {
        region.push(i);
        let k = neighbours(i % w, i / w, w, h, &mut nb);
        for &(nx, ny) in &nb[..k] {
            let j = ny * w + nx;
            if mark[j] == 0 && lum[j] > threshold {
                mark[j] = 1;
                stack.push(j);
            }
        }
    }
    region.sort_unstable();

    // The ring and the fill colour.
    let cc = colour_channels(&env);
    let mut ring_sum = [0.0f64; 3];
    let mut ring_area = 0.0f64;
    let mut region_min = [f64::INFINITY; 3];
    for &i in &region {
        let l = env.rgb(i % w, i / w);
        for ch in 0..3 {
            region_min[ch] = region_min[ch].min(l[ch] as f64);
        }
        let k = neighbours(i % w, i / w, w, h, &mut nb);
        for &(nx, ny) in &nb[..k] {
            let j = ny * w + nx;
            if mark[j] == 0 {
                mark[j] = 2;
                let d_omega = latlong::texel_solid_angle(ny, w, h);
                let l = env.rgb(nx, ny);
                for ch in 0..3 {
                    ring_sum[ch] += l[ch] as f64 * d_omega;
                }
                ring_area += d_omega;
            }
        }
    }
    let fill: [f32; 3] = std::array::from_fn(|ch| {
        let mean = if ring_area > 0.0 { ring_sum[ch] / ring_area } else { 0.0 };
        mean.min(region_min[ch]) as f32
    });
    let fill = if cc == 1 { [fill[0]; 3] } else { fill };

    // The light from what the fill would remove, judged before the map is touched.
    let y_fill = luminance(fill);
    let mut removed = [0.0f64; 3];
    let mut solid_angle = 0.0f64;
    let mut centroid = DVec3::ZERO;
    let mut removed_luminance = 0.0f64;
    for &i in &region {
        let (x, y) = (i % w, i / w);
        let d_omega = latlong::texel_solid_angle(y, w, h);
        let l = env.rgb(x, y);
        for ch in 0..3 {
            removed[ch] += (l[ch] as f64 - fill[ch] as f64) * d_omega;
        }
        solid_angle += d_omega;
        removed_luminance += (lum[i] - y_fill) * d_omega;
        centroid += (lum[i] - y_fill) * d_omega * DVec3::from(latlong::texel_direction(x, y, w, h));
    }
    let direction = unit(centroid).map(|d| d.to_array()).unwrap_or(brightest_dir);
    let share = if total > 0.0 { removed_luminance / total } else { 0.0 };
    if let Some(rejection) = rule.judge(solid_angle, share) {
        let rejected =
            Rejected { rejection, texels: region.len(), radius_deg: cone_radius_deg(solid_angle), share, direction };
        return SunExtraction { rejected: Some(rejected), ..none(env, direction, level, threshold) };
    }

    // The residual: the region filled.
    let mut residual = env;
    for &i in &region {
        let p = residual.pixel_mut(i % w, i / w);
        p[..cc].copy_from_slice(&fill[..cc]);
    }
    let radiance = removed.map(|r| r / solid_angle);
    SunExtraction {
        light: Light { direction, solid_angle, radiance },
        residual,
        level,
        threshold,
        texels: region.len(),
        fill,
        share,
        rejected: None,
    }
}

/// `sum_i Y_i dOmega_i` over a `w x h` map's luminances `lum`: the level's mean and the
/// denominator of the share.
pub(crate) fn luminous_integral(lum: &[f64], w: usize, h: usize) -> f64 {
    (0..h).map(|y| lum[y * w..(y + 1) * w].iter().sum::<f64>() * latlong::texel_solid_angle(y, w, h)).sum()
}

/// The Rec. 709 luminance of every texel of `env`, row-major (f64; rows in parallel).
pub(crate) fn luminances(env: &Image) -> Vec<f64> {
    let w = env.width;
    (0..env.pixel_count()).into_par_iter().map(|i| luminance(env.rgb(i % w, i / w))).collect()
}

/// The reference level `m` of step 1 for the luminances `lum` of a `w x h` map (non-empty) whose
/// [`luminous_integral`] is `integral`: their median (rank `floor(w h / 2)`, rounded to f32), or
/// the solid-angle-weighted mean when the median is not positive.
pub(crate) fn level(lum: &[f64], w: usize, h: usize, integral: f64) -> f64 {
    let area: f64 = (0..h).map(|y| latlong::texel_solid_angle(y, w, h) * w as f64).sum();
    let mean = integral / area;
    // The median of the luminances rounded to f32 (the level only sets the threshold).
    let median = f32_rank(lum, lum.len() / 2) as f64;
    if median > 0.0 {
        median
    } else {
        mean
    }
}

/// The element of rank `k` (from 0, in [`f32::total_cmp`]'s order) of `values` rounded to f32,
/// without a copy of them all: a histogram of the top 16 bits of each value's order-preserving
/// key, then a selection among the values of the bucket that holds rank `k` only. The same value
/// as `select_nth_unstable_by` on an f32 copy, which at 16384 x 8192 would be a third of the map
/// more at the bake's peak (beside the map, its residual and these luminances).
fn f32_rank(values: &[f64], k: usize) -> f32 {
    // total_cmp's order as unsigned integers: negatives with every bit flipped, the rest with the
    // sign bit set.
    let key = |y: f64| {
        let b = (y as f32).to_bits();
        if b >> 31 == 1 {
            !b
        } else {
            b | 0x8000_0000
        }
    };
    let mut histogram = vec![0usize; 1 << 16];
    for &y in values {
        histogram[(key(y) >> 16) as usize] += 1;
    }
    let (mut below, mut bucket) = (0, 0);
    for (i, &count) in histogram.iter().enumerate() {
        if below + count > k {
            bucket = i;
            break;
        }
        below += count;
    }
    let mut candidates: Vec<u32> = values.iter().map(|&y| key(y)).filter(|&x| (x >> 16) as usize == bucket).collect();
    let rank = k - below;
    if rank >= candidates.len() {
        // `k` past the end (no values): no rank to give.
        return f32::NAN;
    }
    let chosen = *candidates.select_nth_unstable(rank).1;
    f32::from_bits(if chosen >> 31 == 1 { chosen & 0x7fff_ffff } else { !chosen })
}

/// `sum_i L_c dOmega_i` per colour channel (f64): the integral conserved by [`extract_sun`].
pub fn integral(env: &Image) -> [f64; 3] {
    let (w, h) = (env.width, env.height);
    (0..h)
        .into_par_iter()
        .map(|y| {
            let d_omega = latlong::texel_solid_angle(y, w, h);
            let mut s = [0.0f64; 3];
            for x in 0..w {
                let l = env.rgb(x, y);
                for ch in 0..3 {
                    s[ch] += l[ch] as f64;
                }
            }
            s.map(|v| v * d_omega)
        })
        .reduce(|| [0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bucketed selection gives what a sort of an f32 copy gives, for every rank, on values
    /// with negatives, zeros of both signs, duplicates and one bucket holding most of them.
    #[test]
    fn f32_rank_is_the_sorted_copys() {
        let mut rng = crate::maths::sampling::sequences::SplitMix64::new(11);
        let mut values: Vec<f64> = (0..3000).map(|_| (rng.next_f64() - 0.3) * 1e3).collect();
        values.extend([0.0, -0.0, 1.0, 1.0, 1.0, 1e-30, -1e30, 65504.0]);
        values.extend((0..2000).map(|i| 1.0 + i as f64 * 1e-7));
        let mut sorted: Vec<f32> = values.iter().map(|&y| y as f32).collect();
        sorted.sort_by(f32::total_cmp);
        for k in (0..values.len()).step_by(7).chain([0, values.len() / 2, values.len() - 1]) {
            assert_eq!(f32_rank(&values, k).to_bits(), sorted[k].to_bits(), "rank {k}");
        }
        assert!(f32_rank(&[], 0).is_nan());
    }
    use std::f64::consts::PI;

    /// `integral(residual) + radiance * solid_angle` against `integral(env)`, worst relative
    /// error over the channels.
    pub(crate) fn conservation_error(env: &Image, s: &SunExtraction) -> f64 {
        let a = integral(env);
        let b = integral(&s.residual);
        let p = s.light.power();
        (0..3).map(|c| ((b[c] + p[c]) - a[c]).abs() / a[c].abs().max(f64::MIN_POSITIVE)).fold(0.0, f64::max)
    }

    /// A sky of radiance `sky` with a disc of angular radius `radius` (radians) around `centre`
    /// at radiance `sun` (texel centres inside the disc).
    fn sky_with_sun(w: usize, h: usize, sky: [f32; 3], sun: [f32; 3], centre: [f64; 3], radius: f64) -> Image {
        let c = DVec3::from(centre).normalize();
        Image::from_fn_rgb(w, h, |x, y| {
            let d = DVec3::from(latlong::texel_direction(x, y, w, h));
            if d.dot(c) > radius.cos() {
                sun
            } else {
                sky
            }
        })
    }

    #[test]
    fn synthetic_sun_is_recovered_exactly() {
        let (w, h) = (512, 256);
        let centre = latlong::direction_deg(40.0, 130.0);
        let radius = 3f64.to_radians();
        let env = sky_with_sun(w, h, [1.0, 0.8, 0.6], [1000.0, 900.0, 700.0], centre, radius);
        let s = extract_sun(&env, 8.0);
        // The median is the sky's luminance; the sun is the region; the ring is sky.
        assert!((s.level - luminance([1.0, 0.8, 0.6])).abs() < 1e-6, "{}", s.level);
        assert_eq!(s.fill, [1.0, 0.8, 0.6]);
        // The residual is the sky everywhere.
        for y in 0..h {
            for x in 0..w {
                assert_eq!(s.residual.rgb(x, y), [1.0, 0.8, 0.6], "({x}, {y})");
            }
        }
        // Radiance: exactly sun - sky (every region texel has the same value).
        for (ch, want) in [999.0, 899.2, 699.4].iter().enumerate() {
            assert!((s.light.radiance[ch] - want).abs() < 1e-9 * want, "{:?}", s.light.radiance);
        }
        // Solid angle: the disc's 2 pi (1 - cos r) up to the texel discretisation.
        let disc = 2.0 * PI * (1.0 - radius.cos());
        assert!((s.light.solid_angle / disc - 1.0).abs() < 0.05, "{} vs {disc}", s.light.solid_angle);
        // Direction: the disc's centre, within a fraction of a texel (0.7 degrees).
        let angle = DVec3::from(s.light.direction).angle_between(DVec3::from(centre)).to_degrees();
        assert!(angle < 0.1, "{angle} degrees off");
        let err = conservation_error(&env, &s);
        assert!(err < 1e-12, "{err}");
    }

    #[test]
    fn sun_across_the_seam_and_the_pole_is_one_region() {
        let (w, h) = (128, 64);
        // Centred on the seam (phi = 0), then on the zenith.
        for centre in [latlong::direction_deg(90.0, 0.0), [0.0, 1.0, 0.0]] {
            let env = sky_with_sun(w, h, [0.5; 3], [300.0; 3], centre, 6f64.to_radians());
            let lit = env.data.iter().filter(|&&v| v == 300.0).count() / 3;
            let s = extract_sun(&env, 4.0);
            assert_eq!(s.texels, lit, "centre {centre:?}");
            let angle = DVec3::from(s.light.direction).angle_between(DVec3::from(centre)).to_degrees();
            assert!(angle < 0.5, "{angle}");
            assert!(conservation_error(&env, &s) < 1e-12);
            assert!(s.residual.data.iter().all(|&v| v == 0.5));
        }
    }

    #[test]
    fn no_sun_uniform_black_and_half_black() {
        for env in [
            Image::from_fn_rgb(32, 16, |_, _| [2.0, 2.0, 2.0]),
            Image::new(32, 16, 3),
            Image::from_fn_rgb(32, 16, |_, y| if y < 8 { [1.0; 3] } else { [0.0; 3] }),
        ] {
            for stops in [0.0, 4.0, 60.0] {
                let s = extract_sun(&env, stops);
                assert_eq!(s.texels, 0);
                assert_eq!(s.light.radiance, [0.0; 3]);
                assert_eq!(s.light.solid_angle, 0.0);
                assert!(s.light.direction.iter().all(|c| c.is_finite()));
                assert_eq!(s.residual.data, env.data);
            }
        }
        // Empty map.
        let s = extract_sun(&Image::new(0, 0, 3), 1.0);
        assert_eq!(s.light.radiance, [0.0; 3]);
    }

    #[test]
    fn mostly_black_map_uses_the_mean_and_finds_a_single_texel() {
        let mut env = Image::new(64, 32, 3);
        env.pixel_mut(10, 5).copy_from_slice(&[5.0, 4.0, 3.0]);
        let s = extract_sun(&env, 2.0);
        assert_eq!(s.texels, 1);
        assert_eq!(s.fill, [0.0; 3]);
        let want = DVec3::from(latlong::texel_direction(10, 5, 64, 32));
        assert!(DVec3::from(s.light.direction).angle_between(want) < 1e-7, "{:?}", s.light.direction);
        assert!(s.residual.data.iter().all(|&v| v == 0.0));
        assert!(conservation_error(&env, &s) < 1e-12);
    }

    #[test]
    fn coloured_ring_never_gives_negative_radiance_and_alpha_is_kept() {
        // A red sun in a blue ring: the ring's blue is above the sun's, so the fill is clamped.
        let (w, h) = (64, 32);
        let centre = latlong::texel_direction(20, 10, w, h);
        let rgb = sky_with_sun(w, h, [0.0, 0.0, 3.0], [400.0, 10.0, 1.0], centre, 8f64.to_radians());
        let mut data = Vec::new();
        for p in rgb.data.chunks(3) {
            data.extend_from_slice(p);
            data.push(0.5);
        }
        let names = ["R", "G", "B", "A"].map(String::from).to_vec();
        let env = Image::with_names(w, h, names, data);
        let s = extract_sun(&env, 1.0);
        assert!(s.texels > 0);
        assert_eq!(s.fill, [0.0, 0.0, 1.0]);
        assert!(s.light.radiance.iter().all(|&r| r >= 0.0), "{:?}", s.light.radiance);
        assert!(s.residual.data.chunks(4).all(|p| p[3] == 0.5));
        assert!(conservation_error(&env, &s) < 1e-12);
    }

    #[test]
    fn grey_and_alpha_map() {
        // Two channels: grey (the first) and alpha; the fill goes into the grey channel only.
        let (w, h) = (32, 16);
        let mut data = Vec::new();
        for i in 0..w * h {
            data.extend_from_slice(&[if i == 5 * w + 7 { 500.0 } else { 2.0 }, 0.25]);
        }
        let env = Image::with_names(w, h, vec!["Y".into(), "A".into()], data);
        let s = extract_sun(&env, 3.0);
        assert_eq!(s.texels, 1);
        assert_eq!(s.fill, [2.0; 3]);
        assert!(s.light.radiance.iter().all(|r| (r - 498.0).abs() < 1e-9), "{:?}", s.light.radiance);
        assert!(s.residual.data.chunks(2).all(|p| p == [2.0, 0.25]));
        assert!(conservation_error(&env, &s) < 1e-12);
    }

    #[test]
    fn real_and_random_maps_conserve_their_integral() {
        let mut rng = crate::maths::sampling::sequences::SplitMix64::new(3);
        let data: Vec<f32> = (0..200 * 100)
            .flat_map(|_| {
                let k = rng_value(&mut rng);
                [k, 0.5 * k, 2.0 * k]
            })
            .collect();
        let env = Image::from_vec(200, 100, 3, data);
        for stops in [0.0, 1.0, 3.0, 10.0] {
            let s = extract_sun(&env, stops);
            let err = conservation_error(&env, &s);
            assert!(err < 1e-10, "stops {stops}: {err}");
            assert!(s.light.radiance.iter().all(|r| r.is_finite() && *r >= 0.0));
        }
        let sky = crate::formats::builtin::builtin("sky").unwrap();
        let s = extract_sun(&sky, 8.0);
        // The built-in sun (anti-aliased edge and aureole included): a few dozen texels, radiance
        // ~45000 minus the sky around it.
        assert!(s.texels > 0 && s.light.solid_angle < 1e-2, "{} texels, {} sr", s.texels, s.light.solid_angle);
        assert!(luminance(s.light.radiance.map(|v| v as f32)) > 1e4, "{:?}", s.light.radiance);
        assert!(conservation_error(&sky, &s) < 1e-10);
    }

    /// The rule on synthetic maps: a sun is taken out; a small lamp carrying a few percent of the
    /// light, and a wide softbox carrying most of it, stay in the map untouched, with the numbers
    /// that decided it.
    #[test]
    fn the_rule_takes_a_sun_but_not_a_lamp_or_a_softbox() {
        let (w, h) = (1024, 512);
        let centre = latlong::direction_deg(30.0, 60.0);
        let sky = [1.0f32; 3];
        let rule = SunRule::DEFAULT;
        // 1 degree at 1e5: ~88% of the light.
        let sun = sky_with_sun(w, h, sky, [1e5; 3], centre, 1f64.to_radians());
        let s = extract_sun_by(sun.clone(), &rule);
        assert!(s.rejected.is_none() && s.texels > 0, "{:?}", s.rejected);
        assert!((s.share - 0.88).abs() < 0.02, "{}", s.share);
        assert!(conservation_error(&sun, &s) < 1e-12);
        // The same disc at 1e3: ~7% of the light, a lamp.
        let lamp = sky_with_sun(w, h, sky, [1e3; 3], centre, 1f64.to_radians());
        let s = extract_sun_by(lamp.clone(), &rule);
        let r = s.rejected.expect("a lamp is not a sun");
        assert!(matches!(r.rejection, super::super::sun_rule::Rejection::TooFaint { .. }), "{r:?}");
        assert!((r.share - 0.07).abs() < 0.01 && (r.radius_deg - 1.0).abs() < 0.1, "{r:?}");
        assert_eq!((s.light.solid_angle, s.texels, s.share), (0.0, 0, 0.0));
        assert_eq!(s.residual.data, lamp.data);
        // 6 degrees at 1e3: ~73% of the light, but wider than a sun.
        let softbox = sky_with_sun(w, h, sky, [1e3; 3], centre, 6f64.to_radians());
        let s = extract_sun_by(softbox.clone(), &rule);
        let r = s.rejected.expect("a softbox is not a sun");
        assert!(matches!(r.rejection, super::super::sun_rule::Rejection::TooLarge { .. }), "{r:?}");
        assert!(r.share > 0.7 && (r.radius_deg - 6.0).abs() < 0.2, "{r:?}");
        assert_eq!(s.residual.data, softbox.data);
        // Without bounds both are taken out.
        assert!(extract_sun(&lamp, 8.0).texels > 0 && extract_sun(&softbox, 8.0).texels > 0);
    }

    fn rng_value(rng: &mut crate::maths::sampling::sequences::SplitMix64) -> f32 {
        let u = rng.next_f64();
        // Mostly dim, a few very bright texels.
        (if u > 0.999 { 1e4 * u } else { u }) as f32
    }
}
