//! The capture maths against a known truth: brackets simulated from the CC0 maps in
//! `assets/maps/` by cameras of known response (`simulate`), their responses recovered
//! (`debevec`, `robertson`) and merged (`merge`), each compared with the truth, and the
//! merge's behaviour on degenerate frames (random, black, white, uncovered, moving).
//!
//! Errors: a response's is the largest `|x / x_true - 1|` over the codes 16..=239 (8 bits) after the best
//! scale per channel ([`Response::max_relative_error`]); a merged map's is the median of
//! `|s E / E_true - 1|` over the samples that are neither clipped nor black in every frame,
//! with `s` the median ratio (the best global scale for a median error, up to the spread).

use super::debevec::debevec;
use super::merge::{merge, merge_maps, Deghost, Maps, Merged, Weight};
use super::response::{Known, Response};
use super::robertson::robertson;
use super::simulate::{simulate, Simulation};
use crate::values::brackets::{Brackets, Codes, Frame};
use crate::values::Image;

fn map(name: &str) -> Image {
    let path = format!("{}/assets/maps/{name}", env!("CARGO_MANIFEST_DIR"));
    crate::formats::rgbe::decode(&std::fs::read(&path).unwrap()).unwrap()
}

/// Five frames two stops apart around an exposure that puts the map's median at 0.18.
fn five_brackets(env: &Image, curve: Known, bits: u8, noise: f64) -> Brackets {
    let mut lum: Vec<f32> = env.data.chunks_exact(env.channels).map(|p| p[1]).collect();
    lum.sort_by(f32::total_cmp);
    let scale = 0.18 / lum[lum.len() / 2] as f64;
    let sim = Simulation {
        times: vec![1.0 / 16.0, 0.25, 1.0, 4.0, 16.0],
        curve,
        bits,
        noise,
        seed: 5,
        shifts: vec![],
        scale,
    };
    simulate(env, &sim).unwrap()
}

/// The median relative error of `m` against `env` after the best scale (module documentation).
fn merge_error(m: &Merged, env: &Image, b: &Brackets) -> f64 {
    let max = b.max_code();
    let usable = |i: usize| {
        let codes: Vec<u16> = b.frames.iter().map(|f| f.codes.get(i)).collect();
        !codes.iter().all(|&z| z == max) && !codes.iter().all(|&z| z == 0)
    };
    let idx: Vec<usize> =
        (0..m.image.len()).filter(|&i| usable(i) && env.data[(i / 3) * env.channels + i % 3] > 0.0).collect();
    let truth = |i: usize| env.data[(i / 3) * env.channels + i % 3] as f64;
    let mut ratios: Vec<f64> = idx.iter().map(|&i| truth(i) / m.image[i] as f64).collect();
    ratios.sort_by(f64::total_cmp);
    let s = ratios[ratios.len() / 2];
    let mut errs: Vec<f64> = idx.iter().map(|&i| (s * m.image[i] as f64 / truth(i) - 1.0).abs()).collect();
    errs.sort_by(f64::total_cmp);
    errs[errs.len() / 2]
}

fn finite(m: &Merged) -> bool {
    m.image.iter().chain(&m.confidence).chain(&m.saturated).all(|v| v.is_finite())
}

#[test]
fn debevec_and_robertson_recover_each_known_response() {
    let env = map("st_fagans_interior_1k.hdr");
    // Codes 16..=239: below, shot and read noise dominate (a code's mean exposure is biased by
    // the noise, whatever the method); above, few pixels. Measured on this map (noise 1, seed 5):
    // Debevec (70 samples) sRGB 7.0%, gamma 2.2 6.8%, S curve 10.9%; Robertson (every pixel)
    // 24.9%, 25.2%, 9.1%, its largest errors at the darkest codes, where its per-code mean of
    // t E over all pixels is pulled by the noise (the regression to the mean of a noisy code).
    // The bounds are those with some margin.
    let mut report = vec![];
    for (curve, bound) in [(Known::Srgb, 0.09), (Known::Gamma22, 0.09), (Known::SCurve, 0.13)] {
        let b = five_brackets(&env, curve, 8, 1.0);
        let truth = Response::known(curve, 8);
        let d = debevec(&b, 10.0, 70).unwrap();
        let r = robertson(&b, 30, 0.01).unwrap();
        let (de, re) = (d.max_relative_error(&truth, 16, 239), r.max_relative_error(&truth, 16, 239));
        eprintln!("{curve}: Debevec {de:.4}, Robertson {re:.4}");
        assert!(d.check().is_ok() && r.check().is_ok());
        report.push((curve, de, re, bound));
    }
    for (curve, de, re, bound) in report {
        assert!(de < bound && re < 0.3, "{curve}: Debevec {de}, Robertson {re}");
    }
}

#[test]
fn five_srgb_brackets_merge_within_the_issue_bound() {
    // Issue 38: at most 3% median relative error after the best scale (OpenCV: 0.4-0.5%).
    // Measured (noise 1, seed 5), calibrated by Debevec with 70 samples: St Fagans 2.7% (hat),
    // 2.6% (Gaussian), 2.6% (noise-optimal); Rooitou park 1.4%, 1.4%, 1.3%. With the true
    // response 0.8% on both: the calibration's error dominates.
    let mut report = vec![];
    for name in ["st_fagans_interior_1k.hdr", "rooitou_park_1k.hdr"] {
        let env = map(name);
        let b = five_brackets(&env, Known::Srgb, 8, 1.0);
        let r = debevec(&b, 10.0, 70).unwrap();
        for w in Weight::ALL {
            let m = merge(&b, &r, w, Deghost::None);
            let err = merge_error(&m, &env, &b);
            eprintln!("{name} {w}: calibrated {err:.4}");
            assert!(finite(&m));
            report.push((name, w.name(), err, 0.03));
        }
        let known = merge(&b, &Response::known(Known::Srgb, 8), Weight::Hat, Deghost::None);
        let err = merge_error(&known, &env, &b);
        eprintln!("{name}: true response {err:.4}");
        report.push((name, "true response", err, 0.01));
    }
    for (name, what, err, bound) in report {
        assert!(err < bound, "{name} {what}: {err}");
    }
}

/// A merge without its per-pixel maps makes the same image, counts and confidence sum.
#[test]
fn a_merge_without_its_maps_makes_the_same_image() {
    let env = map("st_fagans_interior_1k.hdr");
    let b = five_brackets(&env, Known::Srgb, 8, 1.0);
    let r = Response::known(Known::Srgb, 8);
    let all = merge(&b, &r, Weight::Hat, Deghost::Consistency);
    for maps in [
        Maps { confidence: false, saturated: false },
        Maps { confidence: true, saturated: false },
        Maps { confidence: false, saturated: true },
    ] {
        let some = merge_maps(&b, &r, Weight::Hat, Deghost::Consistency, maps);
        assert_eq!(some.image, all.image);
        assert_eq!(
            (some.saturated_pixels, some.dark_pixels, some.dropped),
            (all.saturated_pixels, all.dark_pixels, all.dropped)
        );
        assert_eq!(some.confidence_sum, all.confidence_sum);
        assert_eq!(some.confidence.len(), if maps.confidence { all.confidence.len() } else { 0 });
        assert_eq!(some.saturated.len(), if maps.saturated { all.saturated.len() } else { 0 });
    }
    let sum: f64 = all.confidence.iter().map(|&c| c as f64).sum();
    assert!((sum / all.confidence_sum - 1.0).abs() < 1e-6, "{sum} {}", all.confidence_sum);
}

#[test]
fn sixteen_bit_brackets_calibrate_and_merge() {
    let env = map("studio_small_03_1k.hdr");
    let b = five_brackets(&env, Known::Gamma22, 16, 1.0);
    let r = debevec(&b, 10.0, 200).unwrap();
    let m = merge(&b, &r, Weight::Hat, Deghost::None);
    let err = merge_error(&m, &env, &b);
    let rerr = r.max_relative_error(&Response::known(Known::Gamma22, 16), 4096, 61439);
    eprintln!("16-bit gamma 2.2: merge {err:.4}, response {rerr:.4}");
    // Measured: merge 1.5%, response 4.0%.
    assert!(err < 0.02, "{err}");
    assert!(rerr < 0.06, "{rerr}");
    assert!(finite(&merge(&b, &Response::linear(16), Weight::NoiseOptimal, Deghost::Consistency)));
}

fn frames_of(codes: Vec<Vec<u8>>, w: usize, h: usize) -> Brackets {
    let frames = codes
        .into_iter()
        .enumerate()
        .map(|(i, c)| Frame { name: format!("f{i}"), time: 4f64.powi(i as i32), codes: Codes::U8(c), covered: None })
        .collect();
    Brackets::new(w, h, 8, frames).unwrap()
}

#[test]
fn random_black_and_white_frames_give_finite_outputs() {
    let (w, h) = (31, 7);
    let n = w * h * 3;
    let mut seed = 12345u64;
    let mut next = || {
        seed = crate::maths::sampling::sequences::mix64(seed.wrapping_add(1));
        seed as u8
    };
    let random: Vec<Vec<u8>> = (0..4).map(|_| (0..n).map(|_| next()).collect()).collect();
    let b = frames_of(random, w, h);
    for r in [Response::linear(8), Response::known(Known::Srgb, 8), Response::known(Known::SCurve, 8)] {
        for wt in Weight::ALL {
            for d in Deghost::ALL {
                assert!(finite(&merge(&b, &r, wt, d)), "{wt} {d}");
            }
        }
    }
    // All white: saturated everywhere, each pixel the shortest exposure's value x(255) / 1.
    let r = Response::known(Known::Srgb, 8);
    let white = merge(&frames_of(vec![vec![255; n]; 3], w, h), &r, Weight::Hat, Deghost::Consistency);
    assert!(white.saturated.iter().all(|&s| s == 1.0));
    assert_eq!(white.saturated_pixels, w * h);
    assert!(white.image.iter().all(|&v| v == r.x[0][255] as f32));
    // All black: the longest exposure's x(0) / 16 = 0, counted as underexposed, not saturated.
    let black = merge(&frames_of(vec![vec![0; n]; 3], w, h), &r, Weight::Hat, Deghost::None);
    assert!(black.image.iter().all(|&v| v == 0.0) && black.saturated.iter().all(|&s| s == 0.0));
    assert_eq!(black.dark_pixels, w * h);
    // Clipped in the long frame only, black in the short: the longest frame below the top.
    let mixed = merge(&frames_of(vec![vec![0; n], vec![255; n]], w, h), &r, Weight::Hat, Deghost::None);
    assert!(mixed.image.iter().all(|&v| v == 0.0) && mixed.saturated_pixels == 0);
}

#[test]
fn uncovered_pixels_have_no_weight_and_moving_things_are_dropped() {
    let env = map("rooitou_park_1k.hdr");
    let b = five_brackets(&env, Known::Srgb, 8, 0.0);
    let r = Response::known(Known::Srgb, 8);
    let clean = merge(&b, &r, Weight::Hat, Deghost::None);
    // Frame 1 scrambled where its mask says uncovered: the merge is unchanged there.
    let mut masked = b.clone();
    let px = b.pixel_count();
    let mut mask = vec![1u8; px];
    mask[..px / 2].iter_mut().for_each(|m| *m = 0);
    if let Codes::U8(c) = &mut masked.frames[1].codes {
        c[..px / 2 * 3].iter_mut().for_each(|v| *v = v.wrapping_mul(7).wrapping_add(13));
    }
    masked.frames[1].covered = Some(mask);
    let m = merge(&masked, &r, Weight::Hat, Deghost::None);
    let unchanged_weights = (0..px / 2).all(|p| m.confidence[p] <= clean.confidence[p]);
    assert!(unchanged_weights);
    // A "moving object": a block of frame 3 replaced by mid-grey codes.
    let mut ghost = b.clone();
    let (w, x0, y0, side) = (b.width, 400, 200, 40);
    if let Codes::U8(c) = &mut ghost.frames[3].codes {
        for y in y0..y0 + side {
            for x in x0..x0 + side {
                c[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&[128, 128, 128]);
            }
        }
    }
    let block_error = |m: &Merged| {
        let mut worst = 0f64;
        for y in y0..y0 + side {
            for x in x0..x0 + side {
                for c in 0..3 {
                    let i = (y * w + x) * 3 + c;
                    if clean.confidence[i / 3] > 0.1 {
                        worst = worst.max((m.image[i] as f64 / clean.image[i] as f64 - 1.0).abs());
                    }
                }
            }
        }
        worst
    };
    let plain = merge(&ghost, &r, Weight::Hat, Deghost::None);
    let deghosted = merge(&ghost, &r, Weight::Hat, Deghost::Consistency);
    eprintln!("ghost block: {:.3} without, {:.3} with consistency", block_error(&plain), block_error(&deghosted));
    assert!(block_error(&plain) > 0.3);
    // Ghost pixels whose value falls within the tolerance (10% plus quantisation) are kept.
    assert!(block_error(&deghosted) < 0.15, "{}", block_error(&deghosted));
    // A static, noise-free capture loses no frame.
    assert_eq!(merge(&b, &r, Weight::Hat, Deghost::Consistency).dropped, 0);
}
