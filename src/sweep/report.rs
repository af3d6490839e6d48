//! `hooke sweep report DIR`: every point's result as `results.csv`, a Markdown table
//! (`results.md`) and an accuracy-versus-cost chart (`results.svg`), each point labelled by
//! what varies.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

use super::plan::{Layout, Plan, short_name};
use super::result::{self, Load, PointResult, Status};

/// The results there are, in point order.
pub fn results(dir: &Path, plan: &Plan) -> Vec<PointResult> {
    let layout = Layout::new(dir);
    (0..plan.points.len())
        .filter_map(|i| result::read(&layout.result(i)))
        .collect()
}

fn num(x: Option<f64>) -> String {
    x.map(|x| format!("{x:.6e}")).unwrap_or_default()
}

fn csv_field(s: &str) -> String {
    match s.contains([',', '"', '\n']) {
        true => format!("\"{}\"", s.replace('"', "\"\"")),
        false => s.to_owned(),
    }
}

/// Whether a point ran above `check`'s estimate of its stable step.
fn above_estimate(r: &PointResult) -> bool {
    matches!((r.dt_secs, r.stable_dt_secs), (Some(dt), Some(s)) if dt > s * (1.0 + 1e-9))
}

pub fn csv(plan: &Plan, results: &[PointResult]) -> String {
    let mut out = String::from("index");
    for v in &plan.varied {
        out.push(',');
        out.push_str(&csv_field(v));
    }
    out.push_str(",status,integrator,dt_secs,substeps,steps,masses,stable_dt_secs,above_estimate,wall_secs,repeats,load,steps_per_sec,error_rms_m,balance_change_j,digest,message,notes\n");
    for r in results {
        let _ = write!(out, "{}", r.index);
        for v in &plan.varied {
            let value = r
                .params
                .iter()
                .find(|p| &p.name == v)
                .map(|p| p.value.as_str());
            let _ = write!(out, ",{}", csv_field(value.unwrap_or("")));
        }
        let _ = writeln!(
            out,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.status,
            r.integrator.as_deref().unwrap_or(""),
            num(r.dt_secs),
            r.substeps.map(|s| s.to_string()).unwrap_or_default(),
            r.steps.map(|s| s.to_string()).unwrap_or_default(),
            r.masses.map(|s| s.to_string()).unwrap_or_default(),
            num(r.stable_dt_secs),
            above_estimate(r),
            num(r.wall_secs),
            r.wall_secs_each.len(),
            match r.load {
                Load::Alone => "alone",
                Load::Shared => "shared",
            },
            num(r.steps_per_sec),
            num(r.error_rms_m),
            num(r.energies.map(|e| e.balance_change_j)),
            r.digest.as_deref().unwrap_or(""),
            csv_field(r.message.as_deref().unwrap_or("")),
            csv_field(&r.notes.join(" | ")),
        );
    }
    out
}

pub fn markdown(plan: &Plan, results: &[PointResult]) -> String {
    let mut out = format!(
        "# Sweep of `{}`: {} of {} points\n\n",
        plan.scene,
        results.len(),
        plan.points.len()
    );
    let shared = results.iter().any(|r| r.load == Load::Shared);
    let _ = writeln!(
        out,
        "Wall time is the median of {} run{} of each point, stepping only{}. `*` marks a step above `check`'s estimate of the integrator's stable step.\n",
        plan.repeat,
        if plan.repeat == 1 { "" } else { "s" },
        if shared {
            "; **timed beside other points (parallel load): not clean times**"
        } else {
            ", each point alone"
        }
    );
    out.push_str("| # | point | status | dt (s) | wall (s) | steps/s | error RMS (m) | balance change (J) |\n");
    out.push_str("|---:|---|---|---:|---:|---:|---:|---:|\n");
    for r in results {
        let status = match (&r.status, &r.message, r.notes.first()) {
            (Status::Ok, _, None) | (_, None, None) => r.status.to_string(),
            // What the run warned of stands beside an ok (results.csv has every note).
            (Status::Ok, _, Some(n)) | (_, None, Some(n)) => format!(
                "{}, {} note(s): {}",
                r.status,
                r.notes.len(),
                n.replace('|', "/").lines().next().unwrap_or("")
            ),
            (s, Some(m), _) => format!("{s}: {}", m.replace('|', "/").lines().next().unwrap_or("")),
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {}{} | {} | {} | {} | {} |",
            r.index,
            r.label,
            status,
            r.dt_secs.map(|d| format!("{d:.3e}")).unwrap_or_default(),
            if above_estimate(r) { " *" } else { "" },
            r.wall_secs.map(|d| format!("{d:.3e}")).unwrap_or_default(),
            r.steps_per_sec
                .map(|d| format!("{d:.3e}"))
                .unwrap_or_default(),
            r.error_rms_m
                .map(|d| format!("{d:.3e}"))
                .unwrap_or_default(),
            r.energies
                .map(|e| format!("{:+.3e}", e.balance_change_j))
                .unwrap_or_default(),
        );
    }
    out
}

/// Wall time (x) against error (y), both logarithmic: the error against the reference where the
/// sweep has one, else the size of the energy balance's change.
pub fn svg(plan: &Plan, results: &[PointResult]) -> String {
    let has_error = results.iter().any(|r| r.error_rms_m.is_some());
    let y_of = |r: &PointResult| match has_error {
        true => r.error_rms_m,
        false => r.energies.map(|e| e.balance_change_j.abs()),
    };
    let pts: Vec<(f64, f64, &PointResult)> = results
        .iter()
        .filter(|r| r.status == Status::Ok)
        .filter_map(|r| Some((r.wall_secs?, y_of(r)?, r)))
        .filter(|(x, y, _)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let (w, h, left, right, top, bottom) = (900.0, 600.0, 90.0, 260.0, 50.0, 70.0);
    let span = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x.log10()), hi.max(x.log10()))
        });
        match lo.is_finite() {
            true => (lo.floor(), hi.ceil().max(lo.floor() + 1.0)),
            false => (0.0, 1.0),
        }
    };
    let (x0, x1) = span(&mut pts.iter().map(|p| p.0));
    let (y0, y1) = span(&mut pts.iter().map(|p| p.1));
    let px = |x: f64| left + (x.log10() - x0) / (x1 - x0) * (w - left - right);
    let py = |y: f64| h - bottom - (y.log10() - y0) / (y1 - y0) * (h - top - bottom);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    let _ = writeln!(
        s,
        "<text x=\"{left}\" y=\"24\" font-size=\"15\">{}: {} against wall time, {} of {} points</text>",
        xml(&plan.scene),
        if has_error {
            "error against the reference"
        } else {
            "|energy balance change|"
        },
        pts.len(),
        plan.points.len()
    );
    for k in (x0 as i32)..=(x1 as i32) {
        let x = px(10f64.powi(k));
        let _ = writeln!(
            s,
            "<line x1=\"{x:.1}\" y1=\"{top}\" x2=\"{x:.1}\" y2=\"{:.1}\" stroke=\"#ddd\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">1e{k}</text>",
            h - bottom,
            h - bottom + 16.0
        );
    }
    for k in (y0 as i32)..=(y1 as i32) {
        let y = py(10f64.powi(k));
        let _ = writeln!(
            s,
            "<line x1=\"{left}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">1e{k}</text>",
            w - right,
            left - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">wall time (s, median of {})</text>",
        (left + w - right) / 2.0,
        h - 24.0,
        plan.repeat
    );
    let _ = writeln!(
        s,
        "<text transform=\"translate(22 {:.1}) rotate(-90)\" text-anchor=\"middle\">{}</text>",
        (top + h - bottom) / 2.0,
        if has_error {
            "error RMS (m)"
        } else {
            "|balance change| (J)"
        }
    );
    for (x, y, r) in &pts {
        let label: Vec<String> = r
            .params
            .iter()
            .map(|p| format!("{}={}", short_name(&p.name), p.value))
            .collect();
        let _ = writeln!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"#1f77b4\"><title>{}</title></circle><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">{}</text>",
            px(*x),
            py(*y),
            xml(&r.label),
            px(*x) + 6.0,
            py(*y) + 3.0,
            xml(&label.join(" "))
        );
    }
    let left_out = results.len() - pts.len();
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\">{}</text>\n</svg>",
        w - right + 10.0,
        top + 10.0,
        match left_out {
            0 => String::new(),
            n => format!("{n} point(s) not ok, left out"),
        }
    );
    s
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Write the three files to `out`: their paths.
pub fn write(dir: &Path, plan: &Plan, out: &Path) -> Result<Vec<PathBuf>> {
    let results = results(dir, plan);
    let io =
        |p: &Path, e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let files = [
        ("results.csv", csv(plan, &results)),
        ("results.md", markdown(plan, &results)),
        ("results.svg", svg(plan, &results)),
    ];
    let mut paths = Vec::new();
    for (name, text) in files {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p, e))?;
        paths.push(p);
    }
    Ok(paths)
}
