//! `hooke sweep report DIR`: every point's result as `results.csv`, a Markdown table
//! (`results.md`) and an accuracy-versus-cost chart (`results.svg`), each point labelled by
//! what varies.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

use crate::accuracy::chart::{Chart, ChartPoint, Series, color_of, svg};
use crate::integrator::Integrator;

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
        "Wall time is the median of {} of each point, stepping only{}. `*` marks a step above `check`'s estimate of the integrator's stable step.\n",
        repeats_text(plan),
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
    out.push_str(&cheapest_table(results));
    out
}

/// A point's cost: wall seconds (the median of its timed runs) per simulated second.
fn cost(r: &PointResult) -> Option<f64> {
    let simulated = r.steps? as f64 * r.dt_secs?;
    Some(r.wall_secs? / simulated).filter(|c| c.is_finite())
}

/// The accuracy-versus-cost chart: each ok point's error against the reference (where the
/// sweep has one, else the size of its energy balance's change) against its cost, log–log. A
/// sweep that varies the integrator draws a line per integrator through its points in order
/// of step, each labelled by its other values; any other sweep, its points labelled by theirs.
pub fn chart(plan: &Plan, results: &[PointResult]) -> Chart {
    let has_error = results.iter().any(|r| r.error_rms_m.is_some());
    let by_integrator = plan.varied.iter().any(|v| v == "integrator");
    let y_of = |r: &PointResult| match has_error {
        true => r.error_rms_m,
        false => r.energies.map(|e| e.balance_change_j.abs()),
    };
    let point = |r: &PointResult| {
        let label: Vec<String> = r
            .params
            .iter()
            .filter(|p| !(by_integrator && p.name == "integrator"))
            .map(|p| match p.name.as_str() {
                "dt_secs" => r
                    .dt_secs
                    .map_or_else(|| p.value.clone(), |d| format!("{d:.1e}")),
                _ => format!("{}={}", short_name(&p.name), p.value),
            })
            .collect();
        Some(ChartPoint {
            x: cost(r)?,
            y: y_of(r)?,
            label: label.join(" "),
            title: r.label.clone(),
        })
    };
    let ok: Vec<&PointResult> = results.iter().filter(|r| r.status == Status::Ok).collect();
    let series = match by_integrator {
        true => Integrator::ALL
            .iter()
            .filter_map(|&i| {
                let mut mine: Vec<&&PointResult> = ok
                    .iter()
                    .filter(|r| r.integrator.as_deref() == Some(i.name()))
                    .collect();
                mine.sort_by(|a, b| {
                    b.dt_secs
                        .partial_cmp(&a.dt_secs)
                        .unwrap_or(std::cmp::Ordering::Equal)
                });
                let points: Vec<ChartPoint> = mine.iter().filter_map(|r| point(r)).collect();
                (!points.is_empty()).then(|| Series {
                    name: i.name().to_owned(),
                    color: color_of(i),
                    points,
                })
            })
            .collect(),
        false => vec![Series {
            name: "points".to_owned(),
            color: "#1f77b4",
            points: ok.iter().filter_map(|r| point(r)).collect(),
        }],
    };
    let drawn: usize = series.iter().map(|s| s.points.len()).sum();
    let left_out = results.len() - drawn;
    Chart {
        title: format!(
            "{}: {} against cost, {drawn} of {} points",
            plan.scene,
            if has_error {
                "error against the reference"
            } else {
                "|energy balance change|"
            },
            plan.points.len()
        ),
        x_label: format!(
            "wall time per simulated second (s, median of {})",
            repeats_text(plan)
        ),
        y_label: match has_error {
            true => "error RMS (m)".to_owned(),
            false => "|balance change| (J)".to_owned(),
        },
        series,
        note: (left_out > 0).then(|| format!("{left_out} point(s) diverged or not run: left out")),
    }
}

/// How many runs a point's time is the median of.
fn repeats_text(plan: &Plan) -> String {
    match (plan.repeat, plan.repeat_under_secs) {
        (1, _) => "1 run".to_owned(),
        (n, Some(under)) => format!("up to {n} runs, 1 where it took over {under} s"),
        (n, None) => format!("{n} runs"),
    }
}

/// For each error level, the cheapest ok points that reached it (costs within 10% a tie), where
/// the sweep has a reference.
fn cheapest_table(results: &[PointResult]) -> String {
    if !results.iter().any(|r| r.error_rms_m.is_some()) {
        return String::new();
    }
    let mut out = format!(
        "\n| error RMS at most | cheapest point (within {:.0}% of each other: a tie) | wall s per simulated s |\n|---:|---|---:|\n",
        100.0 * crate::accuracy::TIE_SHARE
    );
    let levels = crate::accuracy::cheapest_per_level(results, |r| {
        (r.status == Status::Ok).then_some((r.error_rms_m?, cost(r)?))
    });
    for (level, tied) in levels {
        let join = |f: &dyn Fn(&PointResult) -> String| {
            tied.iter().map(|r| f(r)).collect::<Vec<_>>().join(" = ")
        };
        match tied.is_empty() {
            true => {
                let _ = writeln!(out, "| {level:.0e} m | none of the points | — |");
            }
            false => {
                let _ = writeln!(
                    out,
                    "| {level:.0e} m | {} | {} |",
                    join(&|r| format!(
                        "#{} {}{}",
                        r.index,
                        r.label,
                        if above_estimate(r) { " *" } else { "" }
                    )),
                    join(&|r| cost(r).map(|c| format!("{c:.3e}")).unwrap_or_default()),
                );
            }
        }
    }
    out
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
        ("results.svg", svg(&chart(plan, &results))),
    ];
    let mut paths = Vec::new();
    for (name, text) in files {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p, e))?;
        paths.push(p);
    }
    Ok(paths)
}
