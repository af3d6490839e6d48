//! The work-precision chart: RMS error against wall time per simulated second, log–log, as SVG.

use std::fmt::Write as _;

use crate::integrator::Integrator;

use super::results::Accuracy;

/// One colour per integrator, in `Integrator::ALL`'s order (a new integrator fails the build
/// until it has its own).
const COLORS: [&str; Integrator::ALL.len()] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#e377c2", "#8c564b",
    "#bcbd22",
];

/// The work-precision chart: RMS error against wall time per simulated second, log–log.
pub fn svg(r: &Accuracy) -> String {
    let pts: Vec<(f64, f64)> = r
        .rows
        .iter()
        .filter(|p| p.stable && p.rms_error_m > 0.0)
        .map(|p| (p.wall_secs_per_sim_sec.max(1e-9), p.rms_error_m))
        .collect();
    let (w, h, ml, mr, mt, mb) = (760.0, 500.0, 80.0, 190.0, 40.0, 60.0);
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
    frame(&plot, r, &mut s);
    series(&plot, r, &mut s);
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
fn frame(plot: &Plot, r: &Accuracy, s: &mut String) {
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
        r#"<text x="{}" y="22" font-size="15">What accuracy costs: {} ({} s simulated)</text>"#,
        ml, r.scene, r.duration_secs
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
        r#"<text x="{}" y="{}" text-anchor="middle">wall time per simulated second (s)</text>"#,
        (ml + w - mr) / 2.0,
        h - 15.0
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{}" transform="rotate(-90 18 {})" text-anchor="middle">RMS position error (m)</text>"#,
        (mt + h - mb) / 2.0,
        (mt + h - mb) / 2.0
    );
}

/// One line of points per integrator, and the legend.
fn series(plot: &Plot, r: &Accuracy, s: &mut String) {
    let Plot { w, mr, mt, .. } = *plot;
    let px = |v: f64| plot.px(v);
    let py = |v: f64| plot.py(v);
    for (k, integrator) in Integrator::ALL.iter().enumerate() {
        let c = COLORS[k];
        let points: Vec<(f64, f64, f64)> = r
            .rows
            .iter()
            .filter(|p| p.integrator == *integrator && p.stable && p.rms_error_m > 0.0)
            .map(|p| {
                let x = px(p.wall_secs_per_sim_sec.max(1e-9));
                (x, py(p.rms_error_m), p.dt_secs)
            })
            .collect();
        let line: Vec<(f64, f64)> = points.iter().map(|&(x, y, _)| (x, y)).collect();
        let path: Vec<String> = line.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
            path.join(" ")
        );
        // Each point names its step.
        for (x, y, dt) in &points {
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{c}"><title>{integrator} at dt = {dt:.3e} s</title></circle><text x="{:.1}" y="{:.1}" font-size="9" fill="{c}">{dt:.1e}</text>"#,
                x + 5.0,
                y - 5.0
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
            integrator
        );
    }
    let _ = writeln!(
        s,
        r##"<text x="{}" y="{}" fill="#666">diverged runs are left out</text>"##,
        w - mr + 15.0,
        // Below the last legend entry, not over one (it overprinted xpbd's).
        mt + 20.0 + 22.0 * Integrator::ALL.len() as f64 + 4.0
    );
}
