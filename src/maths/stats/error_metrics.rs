//! Error metrics of an image against a reference (e.g. a Monte Carlo sphere against
//! `ReferenceSphere`), over the pixels of a mask and all channels.
//!
//! With `e_k = image_k - reference_k` over the `N` selected values (pixels x channels), sums in
//! f64:
//!
//! - `pixels`: the number of selected pixels; `values`: `N`.
//! - `mean_error = (1/N) sum e_k`: the signed bias (0 in expectation for an unbiased estimator).
//! - `mean_abs = (1/N) sum |e_k|`, `max_abs = max |e_k|`.
//! - `rmse = sqrt((1/N) sum e_k^2)`.
//! - `reference_rms = sqrt((1/N) sum reference_k^2)` and
//!   `relative_rmse = rmse / reference_rms`: the RMSE as a fraction of the reference's own RMS
//!   (scale-free, so spheres lit by maps of any brightness compare; this is the "relative RMSE"
//!   quoted in NOTES.md for Mitsuba). 0 when both are 0; +inf when only the reference is 0.
//! - `reference_max = max reference_k` and
//!   `psnr = 20 log10(reference_max / rmse)` in dB (peak signal-to-noise ratio with the
//!   reference's maximum as the peak, as for HDR images there is no fixed white), clamped to
//!   [-999, 999] ([`PSNR_CAP`]) so that identical images (rmse = 0) give 999 and the value
//!   always fits JSON; a reference whose maximum is <= 0 with rmse > 0 gives -999.
//!
//! Non-finite pixel values make the sums non-finite (the metrics then say so; NaN is saved as
//! JSON `null`).

use crate::values::{Image, Metrics};

/// The bound on `psnr` (dB): the value for identical images.
pub const PSNR_CAP: f64 = 999.0;

/// The metrics of `image` against `reference` over the pixels where `mask` is true (all pixels
/// when `None`) and all channels, as named fields in this order: `pixels`, `values`, `rmse`,
/// `relative_rmse`, `mean_abs`, `max_abs`, `mean_error`, `psnr`, `reference_rms`,
/// `reference_max` (definitions in the module documentation).
///
/// Errors: different sizes or channel counts, a mask whose length is not `width * height`, no
/// selected pixel, or no channels.
pub fn image_error(image: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<Metrics, String> {
    if (image.width, image.height, image.channels) != (reference.width, reference.height, reference.channels) {
        return Err(format!(
            "image is {}x{} with {} channel(s), reference is {}x{} with {} channel(s)",
            image.width, image.height, image.channels, reference.width, reference.height, reference.channels
        ));
    }
    let pixels_total = image.width * image.height;
    if let Some(m) = mask {
        if m.len() != pixels_total {
            return Err(format!("mask has {} entries for {pixels_total} pixels", m.len()));
        }
    }
    let c = image.channels;
    if c == 0 {
        return Err("images without channels".into());
    }
    let mut pixels = 0usize;
    let (mut sum_e, mut sum_abs, mut sum_e2, mut sum_r2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut max_abs = 0.0f64;
    let mut ref_max = f64::NEG_INFINITY;
    for p in 0..pixels_total {
        if let Some(m) = mask {
            if !m[p] {
                continue;
            }
        }
        pixels += 1;
        for ch in 0..c {
            let a = image.data[p * c + ch] as f64;
            let r = reference.data[p * c + ch] as f64;
            let e = a - r;
            sum_e += e;
            sum_abs += e.abs();
            sum_e2 += e * e;
            sum_r2 += r * r;
            // f64::max ignores NaN: propagate it explicitly.
            max_abs = if e.is_nan() || max_abs.is_nan() { f64::NAN } else { max_abs.max(e.abs()) };
            ref_max = if r.is_nan() || ref_max.is_nan() { f64::NAN } else { ref_max.max(r) };
        }
    }
    if pixels == 0 {
        return Err("the mask selects no pixel".into());
    }
    let n = (pixels * c) as f64;
    let rmse = (sum_e2 / n).sqrt();
    let reference_rms = (sum_r2 / n).sqrt();
    let relative_rmse = if rmse == 0.0 { 0.0 } else { rmse / reference_rms };
    let psnr = if rmse == 0.0 {
        PSNR_CAP
    } else if ref_max.is_nan() || rmse.is_nan() {
        f64::NAN
    } else if ref_max <= 0.0 {
        -PSNR_CAP
    } else {
        (20.0 * (ref_max / rmse).log10()).clamp(-PSNR_CAP, PSNR_CAP)
    };
    let fields = vec![
        ("pixels".to_string(), pixels as f64),
        ("values".to_string(), n),
        ("rmse".to_string(), rmse),
        ("relative_rmse".to_string(), relative_rmse),
        ("mean_abs".to_string(), sum_abs / n),
        ("max_abs".to_string(), max_abs),
        ("mean_error".to_string(), sum_e / n),
        ("psnr".to_string(), psnr),
        ("reference_rms".to_string(), reference_rms),
        ("reference_max".to_string(), ref_max),
    ];
    Ok(Metrics { fields })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    /// 2 x 1 RGB, by hand: errors (1, 0, -2) and (0, 2, 1), reference (1, 2, 3), (4, 0, 2).
    #[test]
    fn hand_computed_values() {
        let reference = Image::from_vec(2, 1, 3, vec![1.0, 2.0, 3.0, 4.0, 0.0, 2.0]);
        let image = Image::from_vec(2, 1, 3, vec![2.0, 2.0, 1.0, 4.0, 2.0, 3.0]);
        let m = image_error(&image, &reference, None).unwrap();
        assert_eq!(m.get("pixels"), Some(2.0));
        assert_eq!(m.get("values"), Some(6.0));
        // sum e^2 = 1 + 0 + 4 + 0 + 4 + 1 = 10 -> rmse = sqrt(10/6)
        let rmse = (10.0f64 / 6.0).sqrt();
        assert!(close(m.get("rmse").unwrap(), rmse));
        // sum r^2 = 1 + 4 + 9 + 16 + 0 + 4 = 34 -> rms = sqrt(34/6); relative = sqrt(10/34)
        assert!(close(m.get("reference_rms").unwrap(), (34.0f64 / 6.0).sqrt()));
        assert!(close(m.get("relative_rmse").unwrap(), (10.0f64 / 34.0).sqrt()));
        // |e| sum = 6 -> 1; max 2; signed sum = 1 + 0 - 2 + 0 + 2 + 1 = 2 -> 1/3
        assert!(close(m.get("mean_abs").unwrap(), 1.0));
        assert_eq!(m.get("max_abs"), Some(2.0));
        assert!(close(m.get("mean_error").unwrap(), 1.0 / 3.0));
        // psnr = 20 log10(4 / sqrt(10/6)) = 20 log10(3.098387) = 9.822712 dB
        assert!(close(m.get("psnr").unwrap(), 20.0 * (4.0 / rmse).log10()));
        assert!((m.get("psnr").unwrap() - 9.822712).abs() < 1e-6);
        assert_eq!(m.get("reference_max"), Some(4.0));
    }

    #[test]
    fn mask_selects_pixels() {
        let reference = Image::from_vec(3, 1, 1, vec![1.0, 1.0, 1.0]);
        let image = Image::from_vec(3, 1, 1, vec![1.5, 100.0, 0.5]);
        let m = image_error(&image, &reference, Some(&[true, false, true])).unwrap();
        assert_eq!(m.get("pixels"), Some(2.0));
        assert!(close(m.get("rmse").unwrap(), 0.5));
        assert!(close(m.get("relative_rmse").unwrap(), 0.5));
        assert_eq!(m.get("mean_error"), Some(0.0));
        assert_eq!(m.get("max_abs"), Some(0.5));
        // 20 log10(1 / 0.5) = 6.0206 dB
        assert!((m.get("psnr").unwrap() - 6.020600).abs() < 1e-6);
    }

    #[test]
    fn identical_zero_and_bad_inputs() {
        let a = Image::from_vec(2, 2, 3, vec![0.5; 12]);
        let m = image_error(&a, &a, None).unwrap();
        assert_eq!(m.get("rmse"), Some(0.0));
        assert_eq!(m.get("relative_rmse"), Some(0.0));
        assert_eq!(m.get("psnr"), Some(PSNR_CAP));
        let zero = Image::new(2, 2, 3);
        let m = image_error(&a, &zero, None).unwrap();
        assert_eq!(m.get("relative_rmse"), Some(f64::INFINITY));
        assert_eq!(m.get("psnr"), Some(-PSNR_CAP));
        let refused = |e: Result<_, String>, why: &str| e.is_err_and(|e| e == why);
        assert!(refused(
            image_error(&a, &Image::new(2, 2, 1), None),
            "image is 2x2 with 3 channel(s), reference is 2x2 with 1 channel(s)"
        ));
        assert!(refused(
            image_error(&a, &Image::new(2, 3, 3), None),
            "image is 2x2 with 3 channel(s), reference is 2x3 with 3 channel(s)"
        ));
        assert!(refused(image_error(&a, &a, Some(&[true; 3])), "mask has 3 entries for 4 pixels"));
        assert!(refused(image_error(&a, &a, Some(&[false; 4])), "the mask selects no pixel"));
        let mut nan = a.clone();
        nan.data[5] = f32::NAN;
        let m = image_error(&nan, &a, None).unwrap();
        assert!(
            m.get("rmse").unwrap().is_nan() && m.get("max_abs").unwrap().is_nan() && m.get("psnr").unwrap().is_nan()
        );
    }
}
