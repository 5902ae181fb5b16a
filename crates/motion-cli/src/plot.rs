//! Line charts of a metric against the prediction horizon (Euler error at 80..1000 ms, NPSS
//! windows, NDMS bins, ...) for `eval --plot` and `score --plot`: several series with a legend,
//! baselines drawn dashed, one chart per panel in a grid, written as SVG or PNG (by extension,
//! atomically).
//!
//! ```ignore
//! let chart = Chart {
//!     title: "walking: Euler error".into(),
//!     x_label: "horizon (ms)".into(),
//!     y_label: "error".into(),
//!     series: vec![
//!         Series::new("vgru-d", vec![(80.0, 0.3), (160.0, 0.5), (320.0, 0.7)]),
//!         Series::new("zero-velocity", vec![(80.0, 0.39), (160.0, 0.68), (320.0, 0.99)]).dashed(),
//!     ],
//! };
//! plot::write_charts(Path::new("walking.svg"), &[chart], 3)?;
//! ```
#![allow(dead_code)] // Called by the eval and score commands as they adopt --plot.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;

use crate::raster::{Anchor, Canvas, Rgb};
use crate::usage::UsageError;
use motion_core::formats::atomic::write_bytes_atomically;

/// One line of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points, drawn in order; non-finite points are skipped (the line breaks there).
    pub points: Vec<(f64, f64)>,
    /// Drawn dashed (baselines).
    pub dashed: bool,
}

impl Series {
    /// A solid series.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.into(),
            points,
            dashed: false,
        }
    }

    /// The same series, dashed.
    pub fn dashed(mut self) -> Series {
        self.dashed = true;
        self
    }
}

/// One chart: title, axis labels, series.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title above the plot area.
    pub title: String,
    /// X axis label (e.g. `horizon (ms)`).
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
}

/// Writes `charts` in a grid of `columns` panels to `path`: `.svg` or `.png`, through a
/// temporary file and a rename.
pub fn write_charts(path: &Path, charts: &[Chart], columns: usize) -> anyhow::Result<()> {
    let bytes = match check_extension(path)? {
        PlotFormat::Svg => charts_svg(charts, columns).into_bytes(),
        PlotFormat::Png => charts_png(charts, columns)?,
    };
    Ok(write_bytes_atomically(path, &bytes)?)
}

/// The image formats a plot can be written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotFormat {
    /// Scalable vector graphics.
    Svg,
    /// A PNG raster.
    Png,
}

/// The plot format named by `path`'s extension, or a usage error; commands call it before long
/// work so that a bad `--plot` name fails at once.
pub fn check_extension(path: &Path) -> anyhow::Result<PlotFormat> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "svg" => Ok(PlotFormat::Svg),
        "png" => Ok(PlotFormat::Png),
        _ => Err(UsageError(format!(
            "{}: unknown plot format (expected .svg or .png)",
            path.display()
        ))
        .into()),
    }
}

/// The charts as an SVG document.
pub fn charts_svg(charts: &[Chart], columns: usize) -> String {
    let (width, height, shapes) = layout(charts, columns);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width} {height}" width="{width}" height="{height}" font-family="sans-serif">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for shape in &shapes {
        match shape {
            Shape::Line {
                a,
                b,
                width,
                colour,
                dashed,
            } => {
                let dash = if *dashed {
                    r#" stroke-dasharray="6 4""#
                } else {
                    ""
                };
                let _ = writeln!(
                    svg,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="{width}" stroke-linecap="round"{dash}/>"#,
                    a.0,
                    a.1,
                    b.0,
                    b.1,
                    colour.hex()
                );
            }
            Shape::Text {
                at,
                text,
                size,
                anchor,
                colour,
                vertical,
            } => {
                let anchor = match anchor {
                    Anchor::Start => "start",
                    Anchor::Middle => "middle",
                    Anchor::End => "end",
                };
                let rotate = if *vertical {
                    format!(r#" transform="rotate(-90 {:.1} {:.1})""#, at.0, at.1)
                } else {
                    String::new()
                };
                let _ = writeln!(
                    svg,
                    r#"<text x="{:.1}" y="{:.1}" font-size="{size}" text-anchor="{anchor}" dominant-baseline="middle" fill="{}"{rotate}>{}</text>"#,
                    at.0,
                    at.1,
                    colour.hex(),
                    escape(text)
                );
            }
        }
    }
    svg.push_str("</svg>\n");
    svg
}

/// The charts as PNG bytes (drawn at twice the SVG's size).
pub fn charts_png(charts: &[Chart], columns: usize) -> anyhow::Result<Vec<u8>> {
    const S: f64 = 2.0;
    let (width, height, shapes) = layout(charts, columns);
    let mut canvas = Canvas::new((width * S) as usize, (height * S) as usize, Rgb::WHITE);
    let scaled = |p: (f64, f64)| (p.0 * S, p.1 * S);
    for shape in &shapes {
        match shape {
            Shape::Line {
                a,
                b,
                width,
                colour,
                dashed,
            } => {
                if *dashed {
                    canvas.dashed_line(scaled(*a), scaled(*b), width * S, *colour, 12.0, 8.0);
                } else {
                    canvas.line(scaled(*a), scaled(*b), width * S, *colour);
                }
            }
            Shape::Text {
                at,
                text,
                size,
                anchor,
                colour,
                vertical,
            } => {
                let scale = ((size * S / 9.0).round() as usize).max(1);
                let (x, y) = scaled(*at);
                if *vertical {
                    // The bitmap font has no rotation: stack the label's letters.
                    let n = text.chars().count() as f64;
                    let step = 8.0 * scale as f64;
                    for (i, c) in text.chars().enumerate() {
                        let cy = y - n * step / 2.0 + i as f64 * step;
                        canvas.text(x, cy, &c.to_string(), scale, Anchor::Middle, *colour);
                    }
                } else {
                    canvas.text(x, y - 3.5 * scale as f64, text, scale, *anchor, *colour);
                }
            }
        }
    }
    canvas.encode_png().context("encoding the plot as PNG")
}

/// A drawing instruction in SVG user units (the PNG doubles them).
#[derive(Debug, Clone)]
enum Shape {
    Line {
        a: (f64, f64),
        b: (f64, f64),
        width: f64,
        colour: Rgb,
        dashed: bool,
    },
    Text {
        at: (f64, f64),
        text: String,
        size: f64,
        anchor: Anchor,
        colour: Rgb,
        vertical: bool,
    },
}

/// Series colours (Tableau 10).
const COLOURS: [Rgb; 8] = [
    Rgb(31, 119, 180),
    Rgb(255, 127, 14),
    Rgb(44, 160, 44),
    Rgb(214, 39, 40),
    Rgb(148, 103, 189),
    Rgb(140, 86, 75),
    Rgb(227, 119, 194),
    Rgb(127, 127, 127),
];
const AXIS: Rgb = Rgb(60, 60, 60);
const GRIDLINE: Rgb = Rgb(230, 230, 230);

/// Panel size and margins, in SVG units.
const PANEL_W: f64 = 460.0;
const PANEL_H: f64 = 300.0;
const LEFT: f64 = 64.0;
const RIGHT: f64 = 140.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 46.0;

/// Lays out the charts in a grid: (width, height, shapes).
fn layout(charts: &[Chart], columns: usize) -> (f64, f64, Vec<Shape>) {
    let columns = columns.clamp(1, charts.len().max(1));
    let rows = charts.len().div_ceil(columns).max(1);
    let mut shapes = Vec::new();
    for (i, chart) in charts.iter().enumerate() {
        let x0 = (i % columns) as f64 * PANEL_W;
        let y0 = (i / columns) as f64 * PANEL_H;
        panel(chart, x0, y0, &mut shapes);
    }
    (columns as f64 * PANEL_W, rows as f64 * PANEL_H, shapes)
}

/// A "nice" tick step (1, 2 or 5 times a power of ten) for about `count` ticks over `range`.
pub fn nice_step(range: f64, count: usize) -> f64 {
    if !(range.is_finite() && range > 0.0) {
        return 1.0;
    }
    let raw = range / count.max(1) as f64;
    let power = 10f64.powf(raw.log10().floor());
    let m = raw / power;
    let nice = if m <= 1.0 {
        1.0
    } else if m <= 2.0 {
        2.0
    } else if m <= 5.0 {
        5.0
    } else {
        10.0
    };
    nice * power
}

/// A tick label: as few decimals as the step needs.
fn tick_label(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    format!("{v:.decimals$}")
}

fn panel(chart: &Chart, x0: f64, y0: f64, shapes: &mut Vec<Shape>) {
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let points: Vec<&(f64, f64)> = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(finite)
        .collect();
    let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in &points {
        xmin = xmin.min(p.0);
        xmax = xmax.max(p.0);
        ymin = ymin.min(p.1);
        ymax = ymax.max(p.1);
    }
    if points.is_empty() {
        (xmin, xmax, ymin, ymax) = (0.0, 1.0, 0.0, 1.0);
    }
    if ymin >= 0.0 {
        ymin = 0.0; // errors and distances: start the axis at zero
    }
    if xmax <= xmin {
        xmax = xmin + 1.0;
    }
    if ymax <= ymin {
        ymax = ymin + 1.0;
    }
    let ystep = nice_step(ymax - ymin, 5);
    let (ymin, ymax) = (
        (ymin / ystep).floor() * ystep,
        (ymax / ystep).ceil() * ystep,
    );
    let xstep = nice_step(xmax - xmin, 6);
    let (plot_x0, plot_x1) = (x0 + LEFT, x0 + PANEL_W - RIGHT);
    let (plot_y0, plot_y1) = (y0 + TOP, y0 + PANEL_H - BOTTOM);
    let px = |x: f64| plot_x0 + (x - xmin) / (xmax - xmin) * (plot_x1 - plot_x0);
    let py = |y: f64| plot_y1 - (y - ymin) / (ymax - ymin) * (plot_y1 - plot_y0);
    let text = |at, text: String, size, anchor, colour| Shape::Text {
        at,
        text,
        size,
        anchor,
        colour,
        vertical: false,
    };
    let line = |a, b, width, colour| Shape::Line {
        a,
        b,
        width,
        colour,
        dashed: false,
    };

    shapes.push(text(
        (x0 + PANEL_W / 2.0 - RIGHT / 2.0, y0 + 16.0),
        chart.title.clone(),
        14.0,
        Anchor::Middle,
        AXIS,
    ));
    // Horizontal grid lines and y ticks.
    let mut y = ymin;
    while y <= ymax + ystep * 1e-6 {
        shapes.push(line((plot_x0, py(y)), (plot_x1, py(y)), 1.0, GRIDLINE));
        shapes.push(text(
            (plot_x0 - 6.0, py(y)),
            tick_label(y, ystep),
            11.0,
            Anchor::End,
            AXIS,
        ));
        y += ystep;
    }
    // X ticks.
    let mut x = (xmin / xstep).ceil() * xstep;
    while x <= xmax + xstep * 1e-6 {
        shapes.push(line((px(x), plot_y1), (px(x), plot_y1 + 4.0), 1.0, AXIS));
        shapes.push(text(
            (px(x), plot_y1 + 14.0),
            tick_label(x, xstep),
            11.0,
            Anchor::Middle,
            AXIS,
        ));
        x += xstep;
    }
    shapes.push(line((plot_x0, plot_y1), (plot_x1, plot_y1), 1.0, AXIS));
    shapes.push(line((plot_x0, plot_y0), (plot_x0, plot_y1), 1.0, AXIS));
    shapes.push(text(
        ((plot_x0 + plot_x1) / 2.0, plot_y1 + 32.0),
        chart.x_label.clone(),
        12.0,
        Anchor::Middle,
        AXIS,
    ));
    shapes.push(Shape::Text {
        at: (x0 + 14.0, (plot_y0 + plot_y1) / 2.0),
        text: chart.y_label.clone(),
        size: 12.0,
        anchor: Anchor::Middle,
        colour: AXIS,
        vertical: true,
    });

    for (k, series) in chart.series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let pts: Vec<Option<(f64, f64)>> = series
            .points
            .iter()
            .map(|p| (p.0.is_finite() && p.1.is_finite()).then(|| (px(p.0), py(p.1))))
            .collect();
        for pair in pts.windows(2) {
            if let [Some(a), Some(b)] = pair {
                shapes.push(Shape::Line {
                    a: *a,
                    b: *b,
                    width: 2.0,
                    colour,
                    dashed: series.dashed,
                });
            }
        }
        for p in pts.iter().flatten() {
            shapes.push(line(*p, *p, 5.0, colour));
        }
        // Legend entry.
        let ly = plot_y0 + 8.0 + k as f64 * 18.0;
        shapes.push(Shape::Line {
            a: (plot_x1 + 12.0, ly),
            b: (plot_x1 + 34.0, ly),
            width: 2.0,
            colour,
            dashed: series.dashed,
        });
        shapes.push(text(
            (plot_x1 + 40.0, ly),
            series.name.clone(),
            11.0,
            Anchor::Start,
            AXIS,
        ));
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Milliseconds per predicted frame at the protocol's 25 Hz.
const MS_PER_FRAME: f64 = 40.0;
/// Length of one NDMS bin (10 words at 25 Hz).
const NDMS_BIN_MS: f64 = 400.0;

/// Per-frame values at 25 Hz as `(ms, value)`: frame `i` (0-based) ends at `(i + 1) * 40` ms
/// (non-finite values, `null` in the JSON, as NaN: a gap).
pub fn per_frame_points(values: &[f64]) -> Vec<(f64, f64)> {
    numbers(values)
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64 * MS_PER_FRAME, v))
        .collect()
}

/// Window values labelled `"A-B s"` as `(ms at the window centre, value)`, sorted by time
/// (non-finite values, `null` in the JSON, are left out).
pub fn window_points<'a>(windows: impl IntoIterator<Item = (&'a str, f64)>) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = windows
        .into_iter()
        .filter(|(_, value)| value.is_finite())
        .filter_map(|(label, value)| Some((window_centre_ms(label)?, value)))
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points
}

fn window_centre_ms(label: &str) -> Option<f64> {
    let span = label.trim_end_matches('s').trim();
    let (start, end) = span.split_once('-')?;
    let start: f64 = start.trim().parse().ok()?;
    let end: f64 = end.trim().parse().ok()?;
    Some((start + end) * 500.0)
}

/// NDMS 0.4 s bin means as `(ms at the bin's end, value)`.
pub fn bin_points(bins: &[f64]) -> Vec<(f64, f64)> {
    numbers(bins)
        .enumerate()
        .map(|(i, v)| ((i + 1) as f64 * NDMS_BIN_MS, v))
        .collect()
}

fn numbers(values: &[f64]) -> impl Iterator<Item = f64> + '_ {
    values
        .iter()
        .map(|&v| if v.is_finite() { v } else { f64::NAN })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart() -> Chart {
        Chart {
            title: "walking: Euler error".into(),
            x_label: "horizon (ms)".into(),
            y_label: "error".into(),
            series: vec![
                Series::new(
                    "model",
                    vec![(80.0, 0.3), (160.0, 0.5), (320.0, f64::NAN), (400.0, 0.8)],
                ),
                Series::new(
                    "zero-velocity",
                    vec![(80.0, 0.39), (160.0, 0.68), (400.0, 1.1)],
                )
                .dashed(),
            ],
        }
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(1.0, 5), 0.2);
        assert_eq!(nice_step(920.0, 6), 200.0);
        assert_eq!(nice_step(0.0, 5), 1.0);
        assert_eq!(tick_label(0.4, 0.2), "0.4");
        assert_eq!(tick_label(400.0, 200.0), "400");
    }

    #[test]
    fn svg_has_every_series_and_a_dashed_baseline() {
        let svg = charts_svg(&[chart(), chart()], 2);
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("zero-velocity") && svg.contains("model"));
        assert!(svg.contains("stroke-dasharray"));
        assert_eq!(svg.matches("walking: Euler error").count(), 2);
    }

    #[test]
    fn png_and_files_are_written() {
        let bytes = charts_png(&[chart()], 1).unwrap();
        assert_eq!(&bytes[..4], b"\x89PNG");
        let dir = std::env::temp_dir().join(format!("plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write_charts(&dir.join("a.svg"), &[chart()], 1).unwrap();
        write_charts(&dir.join("a.png"), &[chart()], 1).unwrap();
        assert!(write_charts(&dir.join("a.pdf"), &[chart()], 1).is_err());
        assert!(write_charts(&dir.join("missing/a.svg"), &[chart()], 1).is_err());
        assert!(!dir.join("missing").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
