//! Line charts as SVG (linear or log axes, legend beside the plot, several
//! panels per file), drawn with the `plotters` crate's SVG backend.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// Colours of the series, by index (RGB).
pub const COLORS: [(u8, u8, u8); 12] = [
    (0x1f, 0x77, 0xb4),
    (0xd6, 0x27, 0x28),
    (0x2c, 0xa0, 0x2c),
    (0xff, 0x7f, 0x0e),
    (0x94, 0x67, 0xbd),
    (0x8c, 0x56, 0x4b),
    (0xe3, 0x77, 0xc2),
    (0x7f, 0x7f, 0x7f),
    (0xbc, 0xbd, 0x22),
    (0x17, 0xbe, 0xcf),
    (0x00, 0x00, 0x00),
    (0xae, 0xc7, 0xe8),
];

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points (x, y); non-finite or non-positive (on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
    /// Colour index into [`COLORS`].
    pub color: usize,
    /// Dashed line.
    pub dashed: bool,
    /// Draw a marker at each point.
    pub markers: bool,
}

/// One panel.
#[derive(Clone, Debug)]
pub struct Panel {
    /// Title above the panel.
    pub title: String,
    /// X axis label.
    pub xlabel: String,
    /// Y axis label.
    pub ylabel: String,
    /// Logarithmic x.
    pub logx: bool,
    /// Logarithmic y.
    pub logy: bool,
    /// Curves.
    pub series: Vec<Series>,
    /// Fixed x range (else from the data).
    pub xrange: Option<(f64, f64)>,
    /// Fixed y range (else from the data); curves are clipped to it.
    pub yrange: Option<(f64, f64)>,
}

/// Panel size in pixels, and the legend column on its right.
const PW: u32 = 700;
const PH: u32 = 380;
const LEGEND_W: u32 = 280;

fn color(i: usize) -> RGBColor {
    let (r, g, b) = COLORS[i % COLORS.len()];
    RGBColor(r, g, b)
}

/// Tick label: up to 3 significant digits, no float noise
/// (0.30000000000000004 -> "0.3"), exponent form for very large or small.
fn tick(v: &f64) -> String {
    let v = *v;
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        let s = format!("{v:.1e}");
        return s.replace(".0e", "e");
    }
    let digits = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn usable(p: (f64, f64), logx: bool, logy: bool) -> bool {
    p.0.is_finite() && p.1.is_finite() && (!logx || p.0 > 0.0) && (!logy || p.1 > 0.0)
}

/// Data range of one axis, padded (by a factor on log axes).
fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        if hi <= lo * 1.0001 {
            (lo / 2.0, hi * 2.0)
        } else {
            let f = (hi / lo).powf(0.04);
            (lo / f, hi * f)
        }
    } else if hi <= lo {
        (lo - 0.5, hi + 0.5)
    } else {
        let pad = 0.04 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

/// Draws `p` into `area` with the given axis specifications (linear or
/// log ranges from plotters).
fn draw_with<DB, X, Y>(area: &DrawingArea<DB, Shift>, p: &Panel, xs: X, ys: Y)
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let (plot, legend) = area.split_horizontally(PW - LEGEND_W);
    let Ok(mut chart) = ChartBuilder::on(&plot)
        .caption(&p.title, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d(xs, ys)
    else {
        return;
    };
    let _ = chart
        .configure_mesh()
        .x_desc(p.xlabel.as_str())
        .y_desc(p.ylabel.as_str())
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", 11))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw();
    for s in &p.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|&q| usable(q, p.logx, p.logy))
            .collect();
        let style = ShapeStyle::from(color(s.color)).stroke_width(2);
        if s.dashed {
            let _ = chart.draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style));
        } else {
            let _ = chart.draw_series(LineSeries::new(pts.clone(), style));
        }
        if s.markers {
            let _ = chart.draw_series(
                pts.iter()
                    .map(|&q| Circle::new(q, 3, ShapeStyle::from(color(s.color)).filled())),
            );
        }
    }
    // Legend in its own column (never over the curves).
    for (i, s) in p.series.iter().enumerate() {
        let y = 40 + 16 * i as i32;
        let style = ShapeStyle::from(color(s.color)).stroke_width(3);
        if s.dashed {
            let _ = legend.draw(&DashedPathElement::new(vec![(8, y), (30, y)], 5, 3, style));
        } else {
            let _ = legend.draw(&PathElement::new(vec![(8, y), (30, y)], style));
        }
        let _ = legend.draw(&Text::new(
            s.label.clone(),
            (36, y - 6),
            ("sans-serif", 11).into_font(),
        ));
    }
}

fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel) {
    let pts = || {
        p.series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&q| usable(q, p.logx, p.logy))
    };
    let (x0, x1) = p
        .xrange
        .unwrap_or_else(|| range(pts().map(|q| q.0), p.logx));
    let (y0, y1) = p
        .yrange
        .unwrap_or_else(|| range(pts().map(|q| q.1), p.logy));
    match (p.logx, p.logy) {
        (false, false) => draw_with(area, p, x0..x1, y0..y1),
        (true, false) => draw_with(area, p, (x0..x1).log_scale(), y0..y1),
        (false, true) => draw_with(area, p, x0..x1, (y0..y1).log_scale()),
        (true, true) => draw_with(area, p, (x0..x1).log_scale(), (y0..y1).log_scale()),
    }
}

/// An SVG document with `panels` laid out in `cols` columns.
pub fn document(panels: &[Panel], cols: usize) -> String {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (PW * cols as u32, PH * rows as u32))
            .into_drawing_area();
        let _ = root.fill(&WHITE);
        let areas = root.split_evenly((rows, cols));
        for (p, a) in panels.iter().zip(areas.iter()) {
            draw(a, p);
        }
        let _ = root.present();
    }
    out
}
