//! `Difference(a, b, mode: Abs, epsilon: 1e-3)`: an error heat map of `a` against `b`, on three
//! ports.
//!
//! Per pixel, the mean over the C channels of the per-channel error:
//!
//! ```text
//! Abs:       d(x, y) = (1/C) sum_k |a_k - b_k|
//! Relative:  d(x, y) = (1/C) sum_k |a_k - b_k| / (|b_k| + epsilon)
//! ```
//!
//! `epsilon` (default 1e-3, in the image's units) keeps the relative error finite where the
//! reference is black; 1e-3 is well below the darkest texels of the built-in maps and of the
//! captures we use (the sky's darkest is about 0.02), so it only matters where `b` is 0.
//! `a` and `b` must have the same size and the same channel names (all channels count, alpha
//! included). Sums in f64.
//!
//! Ports:
//! - `image` (the default): the heat map as a colour image for `Save` to PNG: d is mapped
//!   linearly from [min, max] (over the finite pixels) to [0, 1] and coloured with matplotlib's
//!   **viridis** (perceptually uniform, readable in greyscale and by colour-blind viewers; by
//!   Nathaniel Smith, Stefan van der Walt and Eric Firing, CC0,
//!   <https://github.com/BIDS/colormap>). `VIRIDIS` holds every 5th entry of its 256-entry table
//!   (entries 0, 5, ..., 255), linearly interpolated, within 0.0025 of the full table (under one
//!   8-bit level). The table is sRGB-encoded; values are stored decoded to linear, so the PNG
//!   (whose encoder applies the sRGB curve) shows the table's colours. Non-finite pixels are
//!   magenta. Below the map, a legend strip `LEGEND_HEIGHT` pixels high: the colour bar from
//!   min (left) to max (right), labelled with both values and the mode. The image is therefore
//!   W x (H + 28).
//! - `error`: d itself, a W x H scalar field named `E`.
//! - `metrics`: `mean`, `max` and `rmse` = sqrt(mean d^2) of the heat map over its finite pixels,
//!   plus `min`, `pixels` and `nonfinite` (the count left out; 0 when both inputs are finite).

use rayon::prelude::*;

use crate::engine::fields::{Check, Input};
use crate::engine::op::{check_same_shape, CheckContext, CheckProblem, OpContext, OpError, OpSpec, Outputs, Persist};
use crate::engine::typed_op::{Op, Port};
use crate::values::ty::*;
use crate::values::{Image, Metrics};

crate::choice! {
    /// Absolute or relative error.
    pub enum DiffMode { Abs, Relative }
}

crate::params! {
    pub struct DifferenceParams {
        /// the image to measure
        #[input(ANY_IMAGE)]
        pub a: Input<Image>,
        /// the reference: same size and channel names
        #[input(ANY_IMAGE)]
        pub b: Input<Image>,
        /// Abs: mean of |a - b| over channels; Relative: mean of |a - b| / (|b| + epsilon)
        pub mode: DiffMode = DiffMode::Abs,
        /// Relative mode: added to |b| so that a black reference gives a finite error
        #[range(1e-9, 1e9)]
        pub epsilon: f64 = 1e-3,
    }
}

/// Height in pixels of the legend strip below the heat map.
pub const LEGEND_HEIGHT: usize = 28;

/// The output ports, declared once: the spec and `eval` name them through these.
const IMAGE: Port<Image> = Port::new("image");
const ERROR: Port<Image> = Port::new("error");
const METRICS: Port<Metrics> = Port::new("metrics");

pub fn spec() -> OpSpec {
    Op::new("Difference", 1, "Error heat map of a against b: colour image with legend, raw field, metrics", eval)
        .port(IMAGE, IMAGE_T, "the heat map in viridis, with a min..max legend below (for PNG)")
        .port(ERROR, SCALAR_T, "the per-pixel error d, a scalar field `E`")
        .port(METRICS, METRICS_T, "mean, max, rmse of d (and min, pixels, nonfinite)")
        .check(check)
        .persist(Persist::IfSmall)
        .into()
}

/// `a` and `b`, when both sizes are known before running, must be equal.
fn check(_: &CheckContext, p: DifferenceParams<Check>) -> Result<(), CheckProblem> {
    check_same_shape(p.a, p.b)
}

/// The per-pixel error d as a scalar field named `E`.
pub fn error_field(a: &Image, b: &Image, mode: DiffMode, epsilon: f64) -> Result<Image, OpError> {
    if (a.width, a.height) != (b.width, b.height) || a.names != b.names {
        return Err(OpError::Invalid(format!(
            "a ({}x{}: {}) and b ({}x{}: {}) must have the same size and channels",
            a.width,
            a.height,
            a.names.join(" "),
            b.width,
            b.height,
            b.names.join(" ")
        )));
    }
    let c = a.channels;
    let data = a
        .data
        .par_chunks_exact(c)
        .zip(b.data.par_chunks_exact(c))
        .map(|(pa, pb)| {
            let sum: f64 = pa
                .iter()
                .zip(pb)
                .map(|(&x, &y)| {
                    let (x, y) = (x as f64, y as f64);
                    match mode {
                        DiffMode::Abs => (x - y).abs(),
                        DiffMode::Relative => (x - y).abs() / (y.abs() + epsilon),
                    }
                })
                .sum();
            (sum / c as f64) as f32
        })
        .collect();
    Ok(Image::with_names(a.width, a.height, vec!["E".into()], data))
}

/// mean, max, rmse, min, pixels, nonfinite of `d` (over its finite samples; f64 sums).
pub fn heat_metrics(d: &[f32]) -> Metrics {
    let finite: Vec<f64> = d.iter().filter(|v| v.is_finite()).map(|&v| v as f64).collect();
    let n = finite.len() as f64;
    let (mean, rmse, min, max) = if finite.is_empty() {
        (f64::NAN, f64::NAN, f64::NAN, f64::NAN)
    } else {
        (
            finite.iter().sum::<f64>() / n,
            (finite.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
            finite.iter().copied().fold(f64::INFINITY, f64::min),
            finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let fields = [
        ("mean", mean),
        ("max", max),
        ("rmse", rmse),
        ("min", min),
        ("pixels", d.len() as f64),
        ("nonfinite", (d.len() - finite.len()) as f64),
    ];
    Metrics { fields: fields.into_iter().map(|(k, v)| (k.to_string(), v)).collect() }
}

/// Every 5th entry (0, 5, ..., 255) of matplotlib's 256-entry viridis table, sRGB-encoded.
const VIRIDIS: [[f64; 3]; 52] = [
    [0.267004, 0.004874, 0.329415],
    [0.273809, 0.031497, 0.358853],
    [0.278791, 0.062145, 0.386592],
    [0.281924, 0.089666, 0.412415],
    [0.283197, 0.115680, 0.436115],
    [0.282623, 0.140926, 0.457517],
    [0.280255, 0.165693, 0.476498],
    [0.276194, 0.190074, 0.493001],
    [0.270595, 0.214069, 0.507052],
    [0.263663, 0.237631, 0.518762],
    [0.255645, 0.260703, 0.528312],
    [0.246811, 0.283237, 0.535941],
    [0.237441, 0.305202, 0.541921],
    [0.227802, 0.326594, 0.546532],
    [0.218130, 0.347432, 0.550038],
    [0.208623, 0.367752, 0.552675],
    [0.199430, 0.387607, 0.554642],
    [0.190631, 0.407061, 0.556089],
    [0.182256, 0.426184, 0.557120],
    [0.174274, 0.445044, 0.557792],
    [0.166617, 0.463708, 0.558119],
    [0.159194, 0.482237, 0.558073],
    [0.151918, 0.500685, 0.557587],
    [0.144759, 0.519093, 0.556572],
    [0.137770, 0.537492, 0.554906],
    [0.131172, 0.555899, 0.552459],
    [0.125394, 0.574318, 0.549086],
    [0.121148, 0.592739, 0.544641],
    [0.119423, 0.611141, 0.538982],
    [0.121380, 0.629492, 0.531973],
    [0.128087, 0.647749, 0.523491],
    [0.140210, 0.665859, 0.513427],
    [0.157851, 0.683765, 0.501686],
    [0.180653, 0.701402, 0.488189],
    [0.208030, 0.718701, 0.472873],
    [0.239374, 0.735588, 0.455688],
    [0.274149, 0.751988, 0.436601],
    [0.311925, 0.767822, 0.415586],
    [0.352360, 0.783011, 0.392636],
    [0.395174, 0.797475, 0.367757],
    [0.440137, 0.811138, 0.340967],
    [0.487026, 0.823929, 0.312321],
    [0.535621, 0.835785, 0.281908],
    [0.585678, 0.846661, 0.249897],
    [0.636902, 0.856542, 0.216620],
    [0.688944, 0.865448, 0.182725],
    [0.741388, 0.873449, 0.149561],
    [0.793760, 0.880678, 0.120005],
    [0.845561, 0.887322, 0.099702],
    [0.896320, 0.893616, 0.096335],
    [0.945636, 0.899815, 0.112838],
    [0.993248, 0.906157, 0.143936],
];

/// Viridis at t in [0, 1] (clamped; NaN -> 0), sRGB-encoded.
pub fn viridis(t: f64) -> [f64; 3] {
    let t = if t > 0.0 { t.min(1.0) } else { 0.0 };
    let pos = t * (VIRIDIS.len() - 1) as f64;
    let k = (pos.floor() as usize).min(VIRIDIS.len() - 2);
    let f = pos - k as f64;
    let (c0, c1) = (VIRIDIS[k], VIRIDIS[k + 1]);
    [0, 1, 2].map(|i| c0[i] + f * (c1[i] - c0[i]))
}

/// The sRGB EOTF (IEC 61966-2-1): encoded value in [0, 1] to linear.
fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Magenta, for pixels whose error is not finite.
const NONFINITE: [f32; 3] = [1.0, 0.0, 1.0];

/// A legend value: plain decimals for ordinary magnitudes, else scientific notation.
fn label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if (1e-3..1e5).contains(&v.abs()) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.3e}")
    }
}

/// The `LEGEND_HEIGHT`-row strip: white, a colour bar (rows 3..13) across the width, and the
/// min, mode and max labels below it. Linear RGB.
fn legend(width: usize, min: f64, max: f64, what: &str) -> Result<Vec<f32>, OpError> {
    use crate::plotting::curves_plot::{ensure_font, FONT};
    use plotters::prelude::*;
    use plotters::style::text_anchor::{HPos, Pos, VPos};

    let fail = |e: String| OpError::Invalid(format!("drawing the legend: {e}"));
    ensure_font().map_err(fail)?;
    let (w32, h32) = (u32::try_from(width).map_err(|_| fail("image too wide".into()))?, LEGEND_HEIGHT as u32);
    let mut buf = vec![255u8; width * LEGEND_HEIGHT * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w32, h32)).into_drawing_area();
        let style = |h: HPos| TextStyle::from((FONT, 12).into_font()).color(&BLACK).pos(Pos::new(h, VPos::Top));
        let right = width as i32 - 3;
        for (text, h, x) in [
            (label(min), HPos::Left, 2),
            (what.to_string(), HPos::Center, width as i32 / 2),
            (label(max), HPos::Right, right),
        ] {
            root.draw_text(&text, &style(h), (x, 14)).map_err(|e| fail(e.to_string()))?;
        }
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let mut out: Vec<f32> = buf.iter().map(|&v| srgb_to_linear(v as f64 / 255.0) as f32).collect();
    for y in 3..13 {
        for x in 0..width {
            let t = if width > 1 { x as f64 / (width - 1) as f64 } else { 0.0 };
            let c = viridis(t).map(|v| srgb_to_linear(v) as f32);
            out[(y * width + x) * 3..(y * width + x + 1) * 3].copy_from_slice(&c);
        }
    }
    Ok(out)
}

/// The heat map of `d` coloured over [min, max], with the legend strip below.
pub fn heat_image(d: &Image, min: f64, max: f64, what: &str) -> Result<Image, OpError> {
    let span = max - min;
    let mut data: Vec<f32> = d
        .data
        .par_iter()
        .flat_map_iter(|&v| {
            if !v.is_finite() {
                return NONFINITE;
            }
            let t = if span > 0.0 { (v as f64 - min) / span } else { 0.0 };
            viridis(t).map(|c| srgb_to_linear(c) as f32)
        })
        .collect();
    data.extend(legend(d.width, min, max, what)?);
    Ok(Image::from_vec(d.width, d.height + LEGEND_HEIGHT, 3, data))
}

fn eval(_: &mut OpContext, p: DifferenceParams) -> Result<Outputs, OpError> {
    let d = error_field(&p.a, &p.b, p.mode, p.epsilon)?;
    let metrics = heat_metrics(&d.data);
    let (min, max) = (metrics.get("min").unwrap_or(0.0), metrics.get("max").unwrap_or(0.0));
    let what = match p.mode {
        DiffMode::Abs => "mean |a - b|".to_string(),
        DiffMode::Relative => format!("mean |a - b| / (|b| + {})", label(p.epsilon)),
    };
    let image = heat_image(&d, min, max, &what)?;
    Ok(Outputs::new().port(IMAGE, image).port(ERROR, d).port(METRICS, metrics))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, data: Vec<f32>) -> Image {
        Image::from_vec(w, data.len() / (3 * w), 3, data)
    }

    #[test]
    fn abs_and_relative_errors_match_their_closed_forms() {
        let a = img(2, vec![1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
        let b = img(2, vec![1.0, 1.0, 1.0, 0.0, 0.0, 2.0]);
        let d = error_field(&a, &b, DiffMode::Abs, 1e-3).unwrap();
        assert_eq!((d.names.clone(), d.data.clone()), (vec!["E".to_string()], vec![1.0, 2.0 / 3.0]));
        let d = error_field(&a, &b, DiffMode::Relative, 1e-3).unwrap();
        let want = [(0.0 + 1.0 / 1.001 + 2.0 / 1.001) / 3.0, (2.0 / 2.001) / 3.0];
        for (got, want) in d.data.iter().zip(want) {
            assert!((*got as f64 - want).abs() < 1e-7);
        }
        assert_eq!(error_field(&a, &a, DiffMode::Relative, 1e-3).unwrap().data, vec![0.0, 0.0]);
        let e = error_field(&a, &Image::new(2, 1, 4), DiffMode::Abs, 1e-3).unwrap_err().to_string();
        assert_eq!(e, "a (2x1: R G B) and b (2x1: R G B A) must have the same size and channels");
    }

    #[test]
    fn metrics_are_mean_max_and_rmse_of_the_finite_pixels() {
        let m = heat_metrics(&[3.0, 4.0, f32::NAN, 0.0]);
        assert_eq!(m.get("mean"), Some(7.0 / 3.0));
        assert_eq!(m.get("max"), Some(4.0));
        assert_eq!(m.get("min"), Some(0.0));
        assert_eq!(m.get("rmse"), Some((25.0f64 / 3.0).sqrt()));
        assert_eq!((m.get("pixels"), m.get("nonfinite")), (Some(4.0), Some(1.0)));
    }

    #[test]
    fn viridis_ends_and_table_entries_between_the_kept_ones() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[51]);
        assert_eq!(viridis(f64::NAN), VIRIDIS[0]);
        // Entries of the full table left out of VIRIDIS (2, 127, 243, 254), within 0.0025.
        let full = [
            (2, [0.269944, 0.014625, 0.341379]),
            (127, [0.128729, 0.563265, 0.551229]),
            (243, [0.876168, 0.891125, 0.095250]),
            (254, [0.983868, 0.904867, 0.136897]),
        ];
        for (i, want) in full {
            let got = viridis(i as f64 / 255.0);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 0.0025, "entry {i}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn the_heat_image_is_viridis_over_min_max_with_a_legend_below() {
        let d = Image::with_names(3, 2, vec!["E".into()], vec![1.0, 2.0, 3.0, 3.0, f32::INFINITY, 1.0]);
        let heat = heat_image(&d, 1.0, 3.0, "test").unwrap();
        assert_eq!((heat.width, heat.height, heat.channels), (3, 2 + LEGEND_HEIGHT, 3));
        let lin = |t: f64| viridis(t).map(|c| srgb_to_linear(c) as f32);
        assert_eq!(heat.pixel(0, 0), lin(0.0));
        assert_eq!(heat.pixel(1, 0), lin(0.5));
        assert_eq!(heat.pixel(2, 0), lin(1.0));
        assert_eq!(heat.pixel(1, 1), NONFINITE);
        // The bar runs from the min colour at the left to the max colour at the right.
        assert_eq!(heat.pixel(0, 2 + 5), lin(0.0));
        assert_eq!(heat.pixel(2, 2 + 5), lin(1.0));
        // Through the PNG encoder the colours come back as the table's 8-bit values.
        let code = crate::formats::srgb8::linear_to_srgb8(heat.pixel(2, 0)[0] as f64);
        assert_eq!(code, (VIRIDIS[51][0] * 255.0).round() as u8);
    }

    #[test]
    fn the_legend_has_labels() {
        // Some pixels of the label rows are dark (text), on a wide enough strip.
        let strip = legend(200, 0.0, 1.5, "mean |a - b|").unwrap();
        let dark = strip[14 * 200 * 3..].chunks_exact(3).filter(|p| p[0] < 0.2).count();
        assert!(dark > 50, "{dark} dark pixels");
        assert_eq!(label(1.5), "1.5");
        assert_eq!(label(2.5e-5), "2.500e-5");
        assert_eq!(label(123456.0), "1.235e5");
    }
}
