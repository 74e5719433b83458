//! A minimal SVG line-chart writer (linear or log axes, legend, several
//! panels per file). Hand-written so that the tools need no plotting crate.

use std::fmt::Write as _;

/// Colours of the series, by index.
pub const COLORS: [&str; 12] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#000000", "#aec7e8",
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
}

const PW: f64 = 580.0;
const PH: f64 = 360.0;
const ML: f64 = 70.0;
const MR: f64 = 240.0;
const MT: f64 = 36.0;
const MB: f64 = 50.0;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn nice_ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if log {
        let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let step = ((b - a) as f64 / 8.0).ceil().max(1.0) as i32;
        // Short ranges also get 2x and 5x ticks.
        let mults: &[f64] = if b - a <= 2 { &[1.0, 2.0, 5.0] } else { &[1.0] };
        (a..=b)
            .step_by(step as usize)
            .flat_map(|e| mults.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| *v >= lo * 0.999 && *v <= hi * 1.001)
            .collect()
    } else {
        let span = (hi - lo).max(1e-300);
        let raw = span / 6.0;
        let mag = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .find(|s| span / s <= 7.0)
            .unwrap_or(10.0 * mag);
        let mut v = Vec::new();
        let mut t = (lo / step).ceil() * step;
        while t <= hi + 1e-9 * span {
            v.push(t);
            t += step;
        }
        v
    }
}

fn fmt_tick(v: f64, log: bool) -> String {
    if !log && v.abs() < 1e-12 {
        return "0".into();
    }
    if log {
        let e = v.log10().round() as i32;
        if (v / 10f64.powi(e) - 1.0).abs() > 1e-6 {
            let e = v.log10().floor() as i32;
            let m = (v / 10f64.powi(e)).round();
            return if (-3..=3).contains(&e) {
                let s = format!("{:.6}", v);
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            } else {
                format!("{m}e{e}")
            };
        }
        match e {
            0 => "1".into(),
            1 => "10".into(),
            2 => "100".into(),
            3 => "1000".into(),
            -1 => "0.1".into(),
            -2 => "0.01".into(),
            -3 => "0.001".into(),
            _ => format!("1e{e}"),
        }
    } else if v.abs() >= 1000.0 || (v != 0.0 && v.abs() < 0.01) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Draws `p` with its top-left corner at (x0, y0) into `out`.
fn draw(p: &Panel, x0: f64, y0: f64, out: &mut String) {
    let ok = |x: f64, log: bool| x.is_finite() && (!log || x > 0.0);
    let pts: Vec<(f64, f64)> = p
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|&(x, y)| ok(x, p.logx) && ok(y, p.logy))
        .collect();
    let (mut xlo, mut xhi) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |a, q| (a.0.min(q.0), a.1.max(q.0)));
    let (mut ylo, mut yhi) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |a, q| (a.0.min(q.1), a.1.max(q.1)));
    if pts.is_empty() {
        (xlo, xhi, ylo, yhi) = (1.0, 10.0, 1.0, 10.0);
    }
    if let Some((a, b)) = p.xrange {
        (xlo, xhi) = (a, b);
    }
    let pad = |lo: f64, hi: f64, log: bool| -> (f64, f64) {
        if log {
            let (a, b) = (lo.log10(), hi.log10());
            let a2 = if b - a < 1.0 {
                a - 0.5
            } else {
                a - 0.05 * (b - a)
            };
            let b2 = if b - a < 1.0 {
                b + 0.5
            } else {
                b + 0.05 * (b - a)
            };
            (10f64.powf(a2.floor().max(a2 - 0.3)), 10f64.powf(b2))
        } else if hi - lo < 1e-12 {
            (lo - 1.0, hi + 1.0)
        } else {
            (lo - 0.04 * (hi - lo), hi + 0.04 * (hi - lo))
        }
    };
    if p.xrange.is_none() {
        (xlo, xhi) = pad(xlo, xhi, p.logx);
    }
    (ylo, yhi) = pad(ylo, yhi, p.logy);
    if !p.logy && ylo > 0.0 && ylo < 0.3 * yhi {
        ylo = 0.0;
    }
    let w = PW - ML - MR;
    let h = PH - MT - MB;
    let tx = |x: f64| {
        let f = if p.logx {
            (x.log10() - xlo.log10()) / (xhi.log10() - xlo.log10())
        } else {
            (x - xlo) / (xhi - xlo)
        };
        x0 + ML + f * w
    };
    let ty = |y: f64| {
        let f = if p.logy {
            (y.log10() - ylo.log10()) / (yhi.log10() - ylo.log10())
        } else {
            (y - ylo) / (yhi - ylo)
        };
        y0 + MT + (1.0 - f) * h
    };
    let _ = writeln!(
        out,
        r##"<rect x="{:.1}" y="{:.1}" width="{w:.1}" height="{h:.1}" fill="none" stroke="#333"/>"##,
        x0 + ML,
        y0 + MT
    );
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="14" text-anchor="middle" font-weight="bold">{}</text>"#,
        x0 + ML + w / 2.0,
        y0 + 22.0,
        esc(&p.title)
    );
    for t in nice_ticks(xlo, xhi, p.logx) {
        let x = tx(t);
        let _ = writeln!(
            out,
            r##"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" font-size="11" text-anchor="middle">{}</text>"##,
            y0 + MT,
            y0 + MT + h,
            y0 + MT + h + 15.0,
            fmt_tick(t, p.logx)
        );
    }
    for t in nice_ticks(ylo, yhi, p.logy) {
        let y = ty(t);
        let _ = writeln!(
            out,
            r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="end">{}</text>"##,
            x0 + ML,
            x0 + ML + w,
            x0 + ML - 4.0,
            y + 4.0,
            fmt_tick(t, p.logy)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">{}</text>"#,
        x0 + ML + w / 2.0,
        y0 + PH - 12.0,
        esc(&p.xlabel)
    );
    let _ = writeln!(
        out,
        r#"<text transform="translate({:.1},{:.1}) rotate(-90)" font-size="12" text-anchor="middle">{}</text>"#,
        x0 + 16.0,
        y0 + MT + h / 2.0,
        esc(&p.ylabel)
    );
    let _ = writeln!(
        out,
        r#"<clipPath id="c{}_{}"><rect x="{:.1}" y="{:.1}" width="{w:.1}" height="{h:.1}"/></clipPath>"#,
        x0 as i64,
        y0 as i64,
        x0 + ML,
        y0 + MT
    );
    for (si, s) in p.series.iter().enumerate() {
        let c = COLORS[s.color % COLORS.len()];
        let good: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|&(x, y)| ok(x, p.logx) && ok(y, p.logy))
            .collect();
        let _ = write!(out, r#"<g clip-path="url(#c{}_{})">"#, x0 as i64, y0 as i64);
        if good.len() > 1 {
            let d: Vec<String> = good
                .iter()
                .map(|&(x, y)| format!("{:.1},{:.1}", tx(x), ty(y)))
                .collect();
            let dash = if s.dashed {
                r#" stroke-dasharray="6,4""#
            } else {
                ""
            };
            let _ = write!(
                out,
                r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="1.8"{dash}/>"#,
                d.join(" ")
            );
        }
        if s.markers || good.len() == 1 {
            for &(x, y) in &good {
                let _ = write!(
                    out,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{c}"/>"#,
                    tx(x),
                    ty(y)
                );
            }
        }
        let _ = writeln!(out, "</g>");
        let ly = y0 + MT + 8.0 + 16.0 * si as f64;
        let lx = x0 + ML + w + 10.0;
        let _ = writeln!(
            out,
            r#"<line x1="{lx:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{c}" stroke-width="2.5"{}/><text x="{:.1}" y="{:.1}" font-size="11">{}</text>"#,
            lx + 18.0,
            if s.dashed {
                r#" stroke-dasharray="4,3""#
            } else {
                ""
            },
            lx + 22.0,
            ly + 4.0,
            esc(&s.label)
        );
    }
}

/// An SVG document with `panels` laid out in `cols` columns.
pub fn document(panels: &[Panel], cols: usize) -> String {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols);
    let (w, h) = (PW * cols as f64, PH * rows as f64);
    let mut out = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">
<rect width="100%" height="100%" fill="white"/>
"#
    );
    for (i, p) in panels.iter().enumerate() {
        draw(p, PW * (i % cols) as f64, PH * (i / cols) as f64, &mut out);
    }
    out.push_str("</svg>\n");
    out
}
