//! The sweep's chart: two log-log panels, RMSE and relMSE against render seconds, one
//! line with dots per series, the reference's own error dashed, the legend and a note
//! under the panels. Drawn with `plotters`' SVG backend; it knows nothing of sweeps and
//! draws the series it is given (`sweep::chart` makes them).

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One line of the chart.
pub struct Series {
    pub label: String,
    /// Each point's seconds, RMSE and relMSE.
    pub points: Vec<[f64; 3]>,
}

/// What the chart shows.
pub struct Chart<'a> {
    pub title: &'a str,
    pub series: &'a [Series],
    /// The reference's own RMSE, drawn as a dashed level in the RMSE panel.
    pub reference_rmse: f64,
    /// A line under the legend: what the points are.
    pub note: String,
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x8c, 0x56, 0x4b),
];

/// The charts' font. `plotters` writes a size of s as s / 1.24 in the SVG: the sizes
/// given here are 1.24 times those drawn (13.5 for 11 px).
const FONT: &str = "sans-serif";

/// The SVG of `chart`: 920x390 pixels.
pub fn svg(chart: &Chart) -> anyhow::Result<String> {
    let mut svg = String::new();
    let drawn = (|| {
        let root = SVGBackend::with_string(&mut svg, (920, 390)).into_drawing_area();
        root.fill(&WHITE)?;
        let (panels, under) = root.split_vertically(340);
        let halves = panels.split_evenly((1, 2));
        let measures = [
            Panel {
                title: format!("{}: RMSE against time", chart.title),
                value: 1,
                reference_level: Some(chart.reference_rmse),
            },
            Panel {
                title: format!("{}: relMSE against time", chart.title),
                value: 2,
                reference_level: None,
            },
        ];
        for (area, measure) in halves.iter().zip(&measures) {
            panel(area, chart.series, measure)?;
        }
        legend(&under, chart)?;
        root.present()
    })();
    drawn.map_err(|e| anyhow::anyhow!("cannot draw the chart: {e}"))?;
    svg.push('\n');
    Ok(svg)
}

/// What one panel plots: its title, which value of a point, and the level of the
/// reference's own error in that measure, if it has one.
struct Panel {
    title: String,
    value: usize,
    reference_level: Option<f64>,
}

/// Powers of ten covering [lo, hi], and 2 and 5 times them when the range is short.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let mults: &[f64] = if b - a <= 2 { &[1.0, 2.0, 5.0] } else { &[1.0] };
    let mut t = Vec::new();
    for e in a..=b {
        for m in mults {
            let v = m * 10f64.powi(e);
            if v >= lo * 0.999 && v <= hi * 1.001 {
                t.push(v);
            }
        }
    }
    t
}

/// A tick label: plain decimals from 0.001 to 9999, else a power of ten (`1e-5`).
fn fmt_tick(v: f64) -> String {
    if (1e-3..1e4).contains(&v) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// The range of `values` (positive ones) widened by 1.3 each way, for a log axis.
fn log_bounds(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo <= hi {
        lo / 1.3..hi * 1.3
    } else {
        0.1..1.0
    }
}

/// One panel: axes, grid, the reference's level dashed and named, a line and dots per
/// series.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    series: &[Series],
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let all = || series.iter().flat_map(|s| &s.points);
    let x_range = log_bounds(all().map(|p| p[0]));
    let y_range = log_bounds(all().map(|p| p[panel.value]).chain(panel.reference_level));
    let (x_lo, x_hi) = (x_range.start, x_range.end);
    let (y_lo, y_hi) = (y_range.start, y_range.end);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, (FONT, 17.5))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(58)
        .build_cartesian_2d(
            x_range.log_scale().with_key_points(log_ticks(x_lo, x_hi)),
            y_range.log_scale().with_key_points(log_ticks(y_lo, y_hi)),
        )?;
    chart
        .configure_mesh()
        .x_desc("render seconds (median)")
        .x_label_formatter(&|v| fmt_tick(*v))
        .y_label_formatter(&|v| fmt_tick(*v))
        .label_style((FONT, 13.5))
        .axis_desc_style((FONT, 15))
        .bold_line_style(RGBColor(0xdd, 0xdd, 0xdd))
        .draw()?;
    if let Some(level) = panel.reference_level.filter(|r| *r > 0.0) {
        let grey = RGBColor(0x88, 0x88, 0x88);
        chart.draw_series(DashedLineSeries::new(
            [(x_lo, level), (x_hi, level)],
            4,
            3,
            grey.into(),
        ))?;
        let style = (FONT, 12.5)
            .into_font()
            .color(&RGBColor(0x66, 0x66, 0x66))
            .pos(Pos::new(HPos::Right, VPos::Bottom));
        // Its label a few pixels left of the right edge and above the line: 1% of
        // the axes' log ranges.
        chart.draw_series(std::iter::once(Text::new(
            "reference's own error",
            (
                x_hi / (x_hi / x_lo).powf(0.01),
                level * (y_hi / y_lo).powf(0.012),
            ),
            style,
        )))?;
    }
    for (i, s) in series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let xy: Vec<(f64, f64)> = s.points.iter().map(|p| (p[0], p[panel.value])).collect();
        chart.draw_series(LineSeries::new(xy.iter().copied(), colour.stroke_width(2)))?;
        chart.draw_series(xy.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
    }
    Ok(())
}

/// The legend under the panels, where it hides no point: each series' colour and label,
/// then the note on a row of its own.
fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let left = Pos::new(HPos::Left, VPos::Center);
    let y = 14;
    let mut x = 80;
    for (i, s) in chart.series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        area.draw(&PathElement::new(
            [(x, y), (x + 22, y)],
            colour.stroke_width(3),
        ))?;
        let style = (FONT, 15).into_font().color(&BLACK).pos(left);
        area.draw(&Text::new(s.label.as_str(), (x + 28, y), style))?;
        x += 40 + 8 * s.label.chars().count() as i32;
    }
    let style = (FONT, 13.5)
        .into_font()
        .color(&RGBColor(0x55, 0x55, 0x55))
        .pos(left);
    area.draw(&Text::new(chart.note.as_str(), (80, y + 20), style))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every series' label once, the reference's level and the note, the ticks of both
    /// axes; a point of error 0 (no place on a log axis) draws no NaN or infinity.
    #[test]
    fn the_chart_holds_every_series() {
        let series: Vec<Series> = [("independent", 0.5), ("sobol", 0.75)]
            .into_iter()
            .map(|(label, slope)| Series {
                label: label.into(),
                points: [1.0f64, 2.0, 4.0, 8.0]
                    .map(|spp| {
                        let rmse = 0.1 / spp.powf(slope);
                        [0.01 * spp, rmse, 10.0 * rmse * rmse]
                    })
                    .to_vec(),
            })
            .collect();
        let chart = Chart {
            title: "test",
            series: &series,
            reference_rmse: 1e-3,
            note: "the note".into(),
        };
        let svg = svg(&chart).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        for label in [
            "independent",
            "sobol",
            "the note",
            "test: RMSE against time",
        ] {
            let entry = format!(">\n{label}\n<");
            assert_eq!(svg.matches(&entry).count(), 1, "{label}");
        }
        assert!(svg.contains("test: relMSE against time"));
        assert!(svg.contains("own error"), "the reference's level");
        for tick in ["0.001", "0.01", "0.1"] {
            assert!(svg.contains(&format!(">\n{tick}\n<")), "tick {tick}");
        }
        let zero = [Series {
            label: "sobol".into(),
            points: vec![[0.01, 0.1, 0.1], [0.02, 0.0, 0.0]],
        }];
        let svg = super::svg(&Chart {
            series: &zero,
            ..chart
        })
        .unwrap();
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
    }
}
