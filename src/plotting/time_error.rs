//! Log-log plots of run time against error, one line per strategy (the benchmark's chart).

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::curves_plot::{area_err, render_png, render_svg, FONT, PALETTE};

/// One strategy's points: (milliseconds, relative error), in increasing sample count.
#[derive(Clone, Debug)]
pub struct Line {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Per point, the half-width of the error's confidence interval, drawn as a vertical bar
    /// error ± ci (its lower end clamped to the axis on the log scale); empty, or 0 or
    /// non-finite for a point: no bar.
    pub ci: Vec<f64>,
}

impl Line {
    /// The half-width of point `i`'s interval, if it has one to draw.
    fn ci_at(&self, i: usize) -> Option<f64> {
        self.ci.get(i).copied().filter(|c| c.is_finite() && *c > 0.0)
    }
}

/// Renders the chart as PNG.
pub fn plot_png(title: &str, lines: &[Line], width: u32, height: u32) -> Result<Vec<u8>, String> {
    render_png(width, height, |root| draw(root, title, lines))
}

/// Renders the chart as SVG.
pub fn plot_svg(title: &str, lines: &[Line], width: u32, height: u32) -> Result<String, String> {
    render_svg(width, height, |root| draw(root, title, lines))
}

/// Powers of ten that enclose the positive finite values.
fn decade_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    (10f64.powf(lo.log10().floor()), 10f64.powf(hi.log10().ceil().max(lo.log10().floor() + 1.0)))
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, title: &str, lines: &[Line]) -> Result<(), String> {
    root.fill(&WHITE).map_err(area_err)?;
    let xs = decade_range(lines.iter().flat_map(|l| l.points.iter().map(|p| p.0)));
    // The range holds the points and the upper ends of their bars (lower ends are clamped).
    let ys = decade_range(
        lines
            .iter()
            .flat_map(|l| l.points.iter().enumerate().flat_map(move |(i, p)| [p.1, p.1 + l.ci_at(i).unwrap_or(0.0)])),
    );
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d((xs.0..xs.1).log_scale(), (ys.0..ys.1).log_scale())
        .map_err(area_err)?;
    chart
        .configure_mesh()
        .x_desc("wall time per image (ms, warm median)")
        .y_desc("relative RMSE vs exact reference")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(area_err)?;
    for (i, line) in lines.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let keep = |(x, y): (f64, f64)| x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0;
        let pts: Vec<(f64, f64)> = line.points.iter().copied().filter(|&p| keep(p)).collect();
        if pts.is_empty() {
            continue;
        }
        // Error bars: mean ± ci; on the log axis the lower end stays above the axis' bottom
        // (an interval reaching 0 or below is drawn down to the axis).
        let bars: Vec<(f64, f64, f64)> = line
            .points
            .iter()
            .enumerate()
            .filter(|&(_, &p)| keep(p))
            .filter_map(|(i, &(x, y))| line.ci_at(i).map(|c| (x, (y - c).max(ys.0), y + c)))
            .collect();
        // A vertical stroke and two caps; the x axis is logarithmic, so a cap spanning x / k to
        // x k has the same width in pixels everywhere.
        let k = 1.06;
        chart
            .draw_series(bars.into_iter().flat_map(|(x, lo, hi)| {
                let mut strokes = vec![
                    PathElement::new(vec![(x, lo), (x, hi)], color.stroke_width(1)),
                    PathElement::new(vec![(x / k, hi), (x * k, hi)], color.stroke_width(1)),
                ];
                // A clamped lower end has no cap: the interval goes on below the axis.
                if lo > ys.0 {
                    strokes.push(PathElement::new(vec![(x / k, lo), (x * k, lo)], color.stroke_width(1)));
                }
                strokes
            }))
            .map_err(area_err)?;
        // Past the palette's length a colour comes round again: its second use is dashed, with
        // triangles for points, so that every line stays distinguishable (22 lines per map).
        if i < PALETTE.len() {
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(area_err)?
                .label(line.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled()))).map_err(area_err)?;
        } else {
            chart
                .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, color.stroke_width(2)))
                .map_err(area_err)?
                .label(line.name.clone())
                .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 18, y)], 6, 4, color.stroke_width(2)));
            chart.draw_series(pts.into_iter().map(|p| TriangleMarker::new(p, 4, color.filled()))).map_err(area_err)?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 12))
        .draw()
        .map_err(area_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_log_log_chart() {
        let lines = vec![
            Line { name: "a".into(), points: vec![(1.0, 0.1), (4.0, 0.05), (16.0, 0.025)], ci: vec![0.01, 0.2, 0.0] },
            Line { name: "b".into(), points: vec![(2.0, 0.2), (8.0, 0.02)], ci: vec![] },
        ];
        let png = plot_png("t", &lines, 640, 400).unwrap();
        let img = image::load_from_memory(&png).unwrap();
        assert_eq!((img.width(), img.height()), (640, 400));
        assert!(plot_svg("t", &lines, 640, 400).unwrap().contains("relative RMSE"));
        assert_eq!(decade_range([0.003, 0.2].into_iter()), (0.001, 1.0));
    }

    #[test]
    fn draws_error_bars_clamped_on_the_log_axis() {
        let with = vec![Line { name: "a".into(), points: vec![(1.0, 0.1), (4.0, 0.05)], ci: vec![0.02, 0.2] }];
        let without = vec![Line { ci: vec![], ..with[0].clone() }];
        let zero = vec![Line { ci: vec![0.0, f64::NAN], ..with[0].clone() }];
        let (a, b, c) = (
            plot_svg("t", &with, 640, 400).unwrap(),
            plot_svg("t", &without, 640, 400).unwrap(),
            plot_svg("t", &zero, 640, 400).unwrap(),
        );
        // Two bars, two or three strokes each (the bar and its caps); none for 0 or NaN.
        let count = |s: &str| s.matches("<line").count() + s.matches("<polyline").count() + s.matches("<path").count();
        assert!(count(&a) >= count(&b) + 2, "{} vs {}", count(&a), count(&b));
        assert_eq!(count(&b), count(&c));
        // The second bar reaches below 0: clamped, nothing non-finite is written.
        assert!(!a.contains("NaN") && !a.contains("inf"));
    }
}
