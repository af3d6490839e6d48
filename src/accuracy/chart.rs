//! The work-precision chart, log–log, as SVG: error against cost, one line of points per
//! series (an integrator), each point labelled (by its step). `bench accuracy`'s chart and
//! `sweep report`'s are this one.

use std::fmt::Write as _;

use crate::integrator::Integrator;

/// One colour per integrator, in `Integrator::ALL`'s order (a new integrator fails the build
/// until it has its own).
const COLORS: [&str; Integrator::ALL.len()] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#e377c2", "#8c564b",
    "#bcbd22",
];

/// The colour of an integrator's line.
pub fn color_of(integrator: Integrator) -> &'static str {
    let k = Integrator::ALL
        .iter()
        .position(|&i| i == integrator)
        .unwrap_or(0);
    COLORS[k % COLORS.len()]
}

/// What a chart shows.
#[derive(Debug, Clone)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Below the legend: what was left out.
    pub note: Option<String>,
}

/// One line of points, in the order given.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub color: &'static str,
    pub points: Vec<ChartPoint>,
}

#[derive(Debug, Clone)]
pub struct ChartPoint {
    pub x: f64,
    pub y: f64,
    /// Beside the point (its step).
    pub label: String,
    /// On hovering it.
    pub title: String,
}

impl ChartPoint {
    /// Both coordinates positive and finite: drawable on log axes.
    fn drawable(&self) -> bool {
        self.x > 0.0 && self.y > 0.0 && self.x.is_finite() && self.y.is_finite()
    }
}

/// The chart as SVG.
pub fn svg(chart: &Chart) -> String {
    let pts: Vec<(f64, f64)> = chart
        .series
        .iter()
        .flat_map(|s| &s.points)
        .filter(|p| p.drawable())
        .map(|p| (p.x, p.y))
        .collect();
    let legend_chars = chart
        .series
        .iter()
        .map(|s| s.name.chars().count())
        .chain(chart.note.iter().map(|n| n.chars().count()))
        .max()
        .unwrap_or(0);
    // The legend's column is as wide as its longest entry (6.5 px a character at 12 px).
    let mr = (60.0 + 6.5 * legend_chars as f64).clamp(120.0, 320.0);
    let (w, h, ml, mt, mb) = (580.0 + mr, 500.0, 80.0, 40.0, 60.0);
    let lx = |v: f64| v.log10();
    let bounds = |f: fn(&(f64, f64)) -> f64| {
        let lo = pts
            .iter()
            .map(|p| lx(f(p)))
            .fold(f64::INFINITY, f64::min)
            .floor();
        let hi = pts
            .iter()
            .map(|p| lx(f(p)))
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil();
        if lo.is_finite() && hi.is_finite() {
            (lo, hi.max(lo + 1.0))
        } else {
            (-3.0, 0.0)
        }
    };
    let (x0, x1) = bounds(|p| p.0);
    let (y0, y1) = bounds(|p| p.1);
    let plot = Plot {
        w,
        h,
        ml,
        mr,
        mt,
        mb,
        x: (x0, x1),
        y: (y0, y1),
    };
    let mut s = String::new();
    frame(&plot, chart, &mut s);
    series(&plot, chart, &mut s);
    s.push_str("</svg>\n");
    s
}

/// The chart's size, margins and decades on each axis.
#[derive(Clone, Copy)]
struct Plot {
    w: f64,
    h: f64,
    ml: f64,
    mr: f64,
    mt: f64,
    mb: f64,
    /// First and last decade (log10) on each axis.
    x: (f64, f64),
    y: (f64, f64),
}

impl Plot {
    fn px(&self, v: f64) -> f64 {
        let (x0, x1) = self.x;
        self.ml + (v.log10() - x0) / (x1 - x0) * (self.w - self.ml - self.mr)
    }
    fn py(&self, v: f64) -> f64 {
        let (y0, y1) = self.y;
        self.h - self.mb - (v.log10() - y0) / (y1 - y0) * (self.h - self.mt - self.mb)
    }
}

/// The frame: title, grid lines with their decades, axis labels.
fn frame(plot: &Plot, chart: &Chart, s: &mut String) {
    let Plot {
        w,
        h,
        ml,
        mr,
        mt,
        mb,
        x: (x0, x1),
        y: (y0, y1),
    } = *plot;
    let px = |v: f64| plot.px(v);
    let py = |v: f64| plot.py(v);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" font-size="15">{}</text>"#,
        ml,
        xml(&chart.title)
    );
    for d in (x0 as i32)..=(x1 as i32) {
        let x = px(10f64.powi(d));
        let _ = writeln!(
            s,
            r##"<line x1="{x}" y1="{mt}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">1e{d}</text>"##,
            h - mb,
            h - mb + 18.0
        );
    }
    for d in (y0 as i32)..=(y1 as i32) {
        let y = py(10f64.powi(d));
        let _ = writeln!(
            s,
            r##"<line x1="{ml}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
            w - mr,
            ml - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        (ml + w - mr) / 2.0,
        h - 15.0,
        xml(&chart.x_label)
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{}" transform="rotate(-90 18 {})" text-anchor="middle">{}</text>"#,
        (mt + h - mb) / 2.0,
        (mt + h - mb) / 2.0,
        xml(&chart.y_label)
    );
}

/// One line of points per series, and the legend.
fn series(plot: &Plot, chart: &Chart, s: &mut String) {
    let Plot { w, mr, mt, .. } = *plot;
    let px = |v: f64| plot.px(v);
    let py = |v: f64| plot.py(v);
    for (k, one) in chart.series.iter().enumerate() {
        let c = one.color;
        let points: Vec<&ChartPoint> = one.points.iter().filter(|p| p.drawable()).collect();
        let path: Vec<String> = points
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.x), py(p.y)))
            .collect();
        if path.len() > 1 {
            let _ = writeln!(
                s,
                r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
                path.join(" ")
            );
        }
        for p in &points {
            let (x, y) = (px(p.x), py(p.y));
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{c}"><title>{}</title></circle><text x="{:.1}" y="{:.1}" font-size="9" fill="{c}">{}</text>"#,
                xml(&p.title),
                x + 5.0,
                y - 5.0,
                xml(&p.label)
            );
        }
        let ly = mt + 20.0 + 22.0 * k as f64;
        let _ = writeln!(
            s,
            r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{c}" stroke-width="3"/><text x="{}" y="{}">{}</text>"#,
            w - mr + 15.0,
            w - mr + 40.0,
            w - mr + 46.0,
            ly + 4.0,
            xml(&one.name)
        );
    }
    if let Some(note) = &chart.note {
        let _ = writeln!(
            s,
            r##"<text x="{}" y="{}" fill="#666">{}</text>"##,
            w - mr + 15.0,
            // Below the last legend entry, not over one (it overprinted xpbd's).
            mt + 20.0 + 22.0 * chart.series.len() as f64 + 4.0,
            xml(note)
        );
    }
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
