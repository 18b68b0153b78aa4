//! A small line-plot writer: axes with round-number ticks, a legend, several
//! series, solid or dashed. Enough to redraw the paper's figures as SVG files
//! without a plotting dependency.

use std::fmt::Write;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stroke {
    Solid,
    Dashed,
    Dotted,
}

#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: &'static str,
    pub stroke: Stroke,
}

impl Series {
    pub fn new(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        color: &'static str,
        stroke: Stroke,
    ) -> Self {
        Self {
            label: label.into(),
            points,
            color,
            stroke,
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed axis ranges; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
}

const WIDTH: f64 = 720.0;
const HEIGHT: f64 = 420.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 55.0;
/// Beyond this many points per series a polyline only adds file size, not detail.
const MAX_POINTS: usize = 2000;

/// The palette the figures use, distinguishable in greyscale print too.
pub const COLORS: [&str; 5] = ["#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad", "#555555"];

impl Plot {
    pub fn to_svg(&self) -> String {
        let (x_min, x_max) = self.x_range.unwrap_or_else(|| {
            extent(
                self.series
                    .iter()
                    .flat_map(|s| s.points.iter().map(|p| p.0)),
            )
        });
        let (y_min, y_max) = self.y_range.unwrap_or_else(|| {
            let (lo, hi) = extent(
                self.series
                    .iter()
                    .flat_map(|s| s.points.iter().map(|p| p.1)),
            );
            let pad = (hi - lo) * 0.05;
            (lo - pad, hi + pad)
        });
        let x_ticks = nice_ticks(x_min, x_max, 10);
        let y_ticks = nice_ticks(y_min, y_max, 8);
        let (x_min, x_max) = (
            x_min.min(x_ticks[0]),
            x_max.max(*x_ticks.last().unwrap_or(&x_max)),
        );
        let (y_min, y_max) = (
            y_min.min(y_ticks[0]),
            y_max.max(*y_ticks.last().unwrap_or(&y_max)),
        );
        let plot_w = WIDTH - LEFT - RIGHT;
        let plot_h = HEIGHT - TOP - BOTTOM;
        let sx = |x: f64| LEFT + (x - x_min) / (x_max - x_min) * plot_w;
        let sy = |y: f64| TOP + (y_max - y) / (y_max - y_min) * plot_h;

        let mut out = String::new();
        let _ = writeln!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="Helvetica, Arial, sans-serif" font-size="12">"#
        );
        let _ = writeln!(
            out,
            r#"<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>"#
        );
        let _ = writeln!(
            out,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="14">{}</text>"#,
            WIDTH / 2.0,
            escape(&self.title)
        );
        for &x in &x_ticks {
            let px = sx(x);
            let _ = writeln!(
                out,
                r##"<line x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{:.1}" stroke="#e4e4e4"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                TOP + plot_h,
                TOP + plot_h + 16.0,
                tick_label(x)
            );
        }
        for &y in &y_ticks {
            let py = sy(y);
            let _ = writeln!(
                out,
                r##"<line x1="{LEFT}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#e4e4e4"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                LEFT + plot_w,
                LEFT - 6.0,
                py + 4.0,
                tick_label(y)
            );
        }
        let _ = writeln!(
            out,
            r#"<rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/>"#
        );
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            LEFT + plot_w / 2.0,
            HEIGHT - 14.0,
            escape(&self.x_label)
        );
        let _ = writeln!(
            out,
            r#"<text x="16" y="{:.1}" text-anchor="middle" transform="rotate(-90 16 {:.1})">{}</text>"#,
            TOP + plot_h / 2.0,
            TOP + plot_h / 2.0,
            escape(&self.y_label)
        );
        let _ = writeln!(
            out,
            r#"<clipPath id="plot-area"><rect x="{LEFT}" y="{TOP}" width="{plot_w}" height="{plot_h}"/></clipPath>"#
        );
        for series in &self.series {
            let stride = series.points.len().div_ceil(MAX_POINTS).max(1);
            let mut path = String::new();
            for (i, &(x, y)) in series.points.iter().enumerate() {
                if i % stride == 0 || i + 1 == series.points.len() {
                    let _ = write!(
                        path,
                        "{:.1},{:.1} ",
                        sx(x),
                        sy(y.clamp(y_min - (y_max - y_min), y_max + (y_max - y_min)))
                    );
                }
            }
            let _ = writeln!(
                out,
                r#"<polyline clip-path="url(#plot-area)" fill="none" stroke="{}" stroke-width="1.6"{} points="{}"/>"#,
                series.color,
                dash(series.stroke),
                path.trim_end()
            );
        }
        let _ = writeln!(
            out,
            r#"<rect x="{:.1}" y="{:.1}" width="196" height="{:.1}" fill="white" fill-opacity="0.85"/>"#,
            LEFT + plot_w - 204.0,
            TOP + 2.0,
            16.0 * self.series.len() as f64 + 6.0
        );
        for (i, series) in self.series.iter().enumerate() {
            let y = TOP + 14.0 + 16.0 * i as f64;
            let x = LEFT + plot_w - 200.0;
            let _ = writeln!(
                out,
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="2"{}/><text x="{:.1}" y="{y:.1}">{}</text>"#,
                y - 4.0,
                x + 28.0,
                y - 4.0,
                series.color,
                dash(series.stroke),
                x + 34.0,
                escape(&series.label)
            );
        }
        out.push_str("</svg>\n");
        out
    }
}

fn dash(stroke: Stroke) -> &'static str {
    match stroke {
        Stroke::Solid => "",
        Stroke::Dashed => r#" stroke-dasharray="7 4""#,
        Stroke::Dotted => r#" stroke-dasharray="2 3""#,
    }
}

fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    match (lo.is_finite(), hi > lo) {
        (true, true) => (lo, hi),
        (true, false) => (lo - 1.0, lo + 1.0),
        _ => (0.0, 1.0),
    }
}

/// Round-number ticks (1, 2 or 5 times a power of ten) covering [min, max].
pub fn nice_ticks(min: f64, max: f64, target: usize) -> Vec<f64> {
    let span = (max - min).abs().max(f64::MIN_POSITIVE);
    let raw = span / target.max(1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude);
    let first = (min / step).floor() as i64;
    let last = (max / step).ceil() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn tick_label(value: f64) -> String {
    let rounded = (value * 1e6).round() / 1e6;
    if rounded == 0.0 {
        "0".to_string()
    } else {
        format!("{rounded}")
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
