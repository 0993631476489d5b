//! Line plots of [`Curves`] (e.g. Fresnel reflectance against angle) as PNG or SVG.
//!
//! Every series is a line in its own colour with a legend entry; the x axis spans the data's x
//! values, the y axis is [0, 1] when every value lies in [0, 1] (reflectances, probabilities) and
//! the data range otherwise; each marker is a dashed vertical line labelled near the top.
//!
//! Fonts: `plotters` is built with `ab_glyph` and no system-font support (see
//! /work/shared/NOTES.md), so the DejaVu Sans TTF shipped in `assets/fonts` is embedded in the
//! binary and registered once as "sans-serif", the only family used here.

use std::sync::OnceLock;

use image::{ExtendedColorType, ImageEncoder};
use plotters::coord::Shift;
use plotters::drawing::DrawingAreaErrorKind;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::values::curves::Curves;

/// The single font family used for all text.
pub(crate) const FONT: &str = "sans-serif";

/// DejaVu Sans (licence in `assets/fonts/DejaVuSans-LICENSE.txt`).
static FONT_BYTES: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/fonts/DejaVuSans.ttf"));

/// Largest accepted width or height, and pixel count, of a plot.
const MAX_SIDE: u32 = 16384;
const MAX_PIXELS: u64 = 64 * 1024 * 1024;

/// Eighteen distinguishable colours (Tableau 10, then darker and lighter variants), so a chart
/// with every strategy and peer of the benchmark never repeats one.
pub(crate) const PALETTE: [RGBColor; 18] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(120, 0, 60),
    RGBColor(0, 90, 50),
    RGBColor(170, 110, 0),
    RGBColor(70, 70, 200),
    RGBColor(255, 80, 180),
    RGBColor(0, 150, 150),
    RGBColor(150, 200, 90),
];

/// Registers the embedded font with plotters exactly once per process (later calls return the
/// first outcome).
pub(crate) fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES)
                .map_err(|_| "the embedded DejaVuSans.ttf is not a valid font".to_string())
        })
        .clone()
}

pub(crate) fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!("plot size {width}x{height}: each side must be in 1..={MAX_SIDE}"));
    }
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(format!("plot size {width}x{height}: more than {MAX_PIXELS} pixels"));
    }
    Ok(())
}

/// Renders `curves` as a `width` x `height` PNG (8-bit RGB).
pub fn plot_png(curves: &Curves, width: u32, height: u32) -> Result<Vec<u8>, String> {
    render_png(width, height, |root| draw(root, curves))
}

/// Renders `curves` as a `width` x `height` SVG document (text stays text, in "sans-serif").
pub fn plot_svg(curves: &Curves, width: u32, height: u32) -> Result<String, String> {
    render_svg(width, height, |root| draw(root, curves))
}

/// Runs `draw` on a `width` x `height` bitmap and encodes it as PNG (8-bit RGB): the size check,
/// the font registration and the encoding every plot shares.
pub(crate) fn render_png(
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<Vec<u8>, String> {
    check_size(width, height)?;
    ensure_font()?;
    let mut buf = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        draw(&root)?;
        root.present().map_err(area_err)?;
        // `root` (and the backend borrowing `buf`) is dropped here.
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&buf, width, height, ExtendedColorType::Rgb8)
        .map_err(|e| format!("PNG encoding failed: {e}"))?;
    Ok(png)
}

/// Runs `draw` on a `width` x `height` SVG document.
pub(crate) fn render_svg(
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    check_size(width, height)?;
    ensure_font()?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        draw(&root)?;
        root.present().map_err(area_err)?;
    }
    Ok(svg)
}

pub(crate) fn area_err<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> String {
    format!("plotting failed: {e}")
}

/// The x range: smallest to largest finite x (for the usual increasing x, the first to the last
/// value); widened by 0.5 each side when degenerate, [0, 1] without finite data.
fn x_range(x: &[f64]) -> (f64, f64) {
    widen(finite_min_max(x.iter().copied()), (0.0, 1.0))
}

/// The y range: [0, 1] when every finite value lies in it; otherwise the data range padded by 5%.
fn y_range(curves: &Curves) -> (f64, f64) {
    let all = curves.series.iter().flat_map(|(_, ys)| ys.iter().copied());
    match finite_min_max(all) {
        None => (0.0, 1.0),
        Some((lo, hi)) if lo >= 0.0 && hi <= 1.0 => (0.0, 1.0),
        Some((lo, hi)) => {
            let pad = 0.05 * (hi - lo);
            widen(Some((lo - pad, hi + pad)), (0.0, 1.0))
        }
    }
}

fn finite_min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.filter(|v| v.is_finite()).fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

fn widen(range: Option<(f64, f64)>, fallback: (f64, f64)) -> (f64, f64) {
    match range {
        None => fallback,
        Some((lo, hi)) if hi > lo && (hi - lo).is_finite() => (lo, hi),
        Some((lo, _)) => {
            let half = if lo == 0.0 { 0.5 } else { 0.5 * lo.abs().max(1e-300) };
            (lo - half, lo + half)
        }
    }
}

/// Splits a series into runs of consecutive points where both x and y are finite (a NaN breaks
/// the line instead of corrupting it).
fn finite_runs(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut current = Vec::new();
    for (&a, &b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            current.push((a, b));
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

/// Draws the whole chart on `root` (any backend).
fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, curves: &Curves) -> Result<(), String> {
    root.fill(&WHITE).map_err(area_err)?;
    let (x0, x1) = x_range(&curves.x);
    let (y0, y1) = y_range(curves);

    let mut builder = ChartBuilder::on(root);
    builder.margin(15).x_label_area_size(45).y_label_area_size(60);
    if !curves.title.is_empty() {
        builder.caption(curves.title.as_str(), (FONT, 20));
    }
    let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1).map_err(area_err)?;

    chart
        .configure_mesh()
        .x_desc(curves.x_label.as_str())
        .y_desc(curves.y_label.as_str())
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .bold_line_style(RGBColor(200, 200, 200))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(area_err)?;

    for (i, (name, ys)) in curves.series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let style = color.stroke_width(2);
        let runs = finite_runs(&curves.x, ys);
        chart
            .draw_series(runs.into_iter().map(move |run| PathElement::new(run, style)))
            .map_err(area_err)?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }

    // Markers: dashed vertical lines, labels staggered downwards so neighbours do not overlap,
    // placed right of the line (left of it in the rightmost quarter of the plot).
    let marker_color = RGBColor(80, 80, 80);
    for (k, (label, mx)) in curves.markers.iter().enumerate() {
        let mx = *mx;
        if !mx.is_finite() || mx < x0 || mx > x1 {
            continue;
        }
        chart
            .draw_series(DashedLineSeries::new(vec![(mx, y0), (mx, y1)], 6, 4, marker_color.stroke_width(1)))
            .map_err(area_err)?;
        let right_side = mx > x0 + 0.75 * (x1 - x0);
        let (dx, h_pos) = if right_side { (-5, HPos::Right) } else { (5, HPos::Left) };
        let dy = 5 + 18 * (k as i32 % 4);
        let text_style = TextStyle::from((FONT, 13).into_font()).color(&BLACK).pos(Pos::new(h_pos, VPos::Top));
        chart
            .draw_series(std::iter::once(EmptyElement::at((mx, y1)) + Text::new(label.clone(), (dx, dy), text_style)))
            .map_err(area_err)?;
    }

    if !curves.series.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .draw()
            .map_err(area_err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::brdf::fresnel::fresnel_curves;

    fn sample_curves() -> Curves {
        Curves {
            title: "test".into(),
            x_name: "x".into(),
            x_label: "x label".into(),
            y_label: "y label".into(),
            x: vec![0.0, 1.0, 2.0, 3.0],
            series: vec![("a".into(), vec![0.0, 0.5, 0.25, 1.0]), ("b".into(), vec![1.0, f64::NAN, 0.5, 0.0])],
            scalars: vec![],
            markers: vec![("mark one".into(), 1.5), ("outside".into(), 10.0)],
        }
    }

    #[test]
    fn png_decodes_to_size_and_is_not_blank() {
        let png = plot_png(&fresnel_curves(1.0, 1.5, 91), 640, 480).unwrap();
        let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (640, 480));
        let white = img.pixels().filter(|p| p.0 == [255, 255, 255]).count();
        let total = 640 * 480;
        assert!(white < total, "blank image");
        // Drawn content (axes, text, lines) covers a visible share, but the background dominates.
        assert!(white > total / 2, "{white}");
        // The series colours appear (first palette colour: the "rs" line), allowing for blending.
        let c0 = PALETTE[0];
        let near = |p: &image::Rgb<u8>| {
            (p.0[0] as i32 - c0.0 as i32).abs() <= 40
                && (p.0[1] as i32 - c0.1 as i32).abs() <= 40
                && (p.0[2] as i32 - c0.2 as i32).abs() <= 40
        };
        assert!(img.pixels().filter(|p| near(p)).count() > 50);
    }

    #[test]
    fn svg_has_marker_labels_and_titles() {
        let svg = plot_svg(&fresnel_curves(1.5, 1.0, 91), 640, 480).unwrap();
        assert!(svg.starts_with("<svg") || svg.contains("<svg"));
        assert!(svg.contains("Brewster"));
        assert!(svg.contains("Brewster 33.69°"), "{svg}");
        assert!(svg.contains("critical 41.81°"));
        assert!(svg.contains("angle of incidence (degrees)"));
        assert!(svg.contains("reflectance"));
        assert!(svg.contains("Fresnel reflectance, eta 1.5 -&gt; 1"));
        assert!(svg.contains("sans-serif"));
        let one = plot_svg(&fresnel_curves(1.0, 1.5, 91), 640, 480).unwrap();
        assert!(one.contains("Brewster 56.31°"));
        assert!(!one.contains("critical"));
    }

    #[test]
    fn handles_nan_out_of_range_markers_and_wide_data() {
        let mut c = sample_curves();
        let svg = plot_svg(&c, 400, 300).unwrap();
        assert!(svg.contains("mark one"));
        assert!(!svg.contains("outside"));
        c.series[0].1[3] = 7.5;
        let png = plot_png(&c, 400, 300).unwrap();
        assert!(!png.is_empty());
        let (lo, hi) = y_range(&c);
        assert!((lo + 0.375).abs() < 1e-12 && (hi - 7.875).abs() < 1e-12, "{lo} {hi}");
    }

    #[test]
    fn ranges() {
        assert_eq!(x_range(&[0.0, 90.0]), (0.0, 90.0));
        assert_eq!(x_range(&[]), (0.0, 1.0));
        assert_eq!(x_range(&[2.0, 2.0]), (1.0, 3.0));
        assert_eq!(x_range(&[0.0]), (-0.5, 0.5));
        let mut c = sample_curves();
        assert_eq!(y_range(&c), (0.0, 1.0));
        c.series.clear();
        assert_eq!(y_range(&c), (0.0, 1.0));
        assert_eq!(finite_runs(&[0.0, 1.0, 2.0, 3.0], &[1.0, f64::NAN, 2.0, 3.0]).len(), 2);
    }

    #[test]
    fn empty_curves_and_bad_sizes() {
        let c = Curves {
            title: String::new(),
            x_name: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x: vec![],
            series: vec![],
            scalars: vec![],
            markers: vec![],
        };
        assert!(plot_png(&c, 200, 100).is_ok());
        assert!(plot_svg(&c, 200, 100).is_ok());
        assert_eq!(plot_png(&c, 0, 100).unwrap_err(), "plot size 0x100: each side must be in 1..=16384");
        assert_eq!(plot_svg(&c, 100, MAX_SIDE + 1).unwrap_err(), "plot size 100x16385: each side must be in 1..=16384");
    }
}
