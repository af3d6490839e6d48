//! The report of a measurement: Markdown (with the "which solver for this accuracy" guidance),
//! CSV, the files they are written to, and the same series as a Rerun recording.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::integrator::Integrator;

use super::results::{Accuracy, Found, Row};

fn fmt_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "—".to_owned()
    }
}

pub fn markdown(r: &Accuracy) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Scene `{}`, {} s simulated, against f64 RK4 at dt = {:.3e} s. Wall time: the median of {}{}.\n",
        r.scene,
        r.duration_secs,
        r.reference_dt_secs,
        repeats_text(r.repeats),
        match r.timed_alone {
            true => "",
            false => "; **timed beside other runs (parallel load): not clean times**",
        }
    );
    let _ = writeln!(
        s,
        "| integrator | dt (s) | steps | RMS error (m) | max error (m) | energy drift (J) | stable | energy dissipated (% of initial) | wall s per sim s | backend |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---|---:|---:|---|");
    for row in &r.rows {
        let _ = writeln!(
            s,
            "| {} | {:.3e}{} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.integrator,
            row.dt_secs,
            if row.at_estimate {
                " (the estimate)"
            } else {
                ""
            },
            row.steps,
            fmt_num(row.rms_error_m),
            fmt_num(row.max_error_m),
            fmt_num(row.energy_drift_j),
            row.outcome.label().replace('|', "/"),
            if row.dissipated_pct.is_finite() {
                format!("{:.1}", row.dissipated_pct)
            } else {
                "—".to_owned()
            },
            fmt_num(row.wall_secs_per_sim_sec),
            row.backend
        );
    }
    let _ = writeln!(
        s,
        "\n| integrator | estimated stable dt (`hooke check`) | largest stable dt measured | dt searched |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|");
    for st in &r.stable {
        let est = match st.estimate {
            Some(e) if e.is_finite() => format!("{e:.3e} s"),
            Some(_) => "any".to_owned(),
            None => "none for sure (docs/stability.md)".to_owned(),
        };
        let found = match st.found {
            Found::Largest(f) => format!("{f:.3e} s"),
            Found::AtLeast(f) => format!("≥ {f:.3e} s (largest tried)"),
            Found::Unstable => "unstable at every dt tried".to_owned(),
        };
        let _ = writeln!(
            s,
            "| {} | {est} | {found} | {:.3e} – {:.3e} s |",
            st.integrator, st.searched.0, st.searched.1
        );
    }
    s.push_str(&guidance(r));
    s.push_str(&at_frame_rate(r));
    s
}

/// How many timed runs a row's wall time is the median of, in words.
fn repeats_text(r: super::timing::Repeats) -> String {
    match (r.most.max(1), r.while_first_under_secs) {
        (1, _) => "1 timed run of each point".to_owned(),
        (n, Some(under)) => format!(
            "{n} timed runs of each point whose first took under {under} s (1 of the others)"
        ),
        (n, None) => format!("{n} timed runs of each point"),
    }
}

/// The fast end: each solver at one step per frame, cheapest first, and how wrong it is there
/// ("what is the cheapest way to run this scene at one step per frame, and how wrong is it").
fn at_frame_rate(r: &Accuracy) -> String {
    let Some(frame_dt) = r.frame_dt_secs else {
        return String::new();
    };
    let mut rows: Vec<&Row> = r
        .rows
        .iter()
        .filter(|row| (row.dt_secs / frame_dt - 1.0).abs() < 1e-9)
        .collect();
    rows.sort_by(|a, b| {
        (!a.outcome.is_stable(), a.wall_secs_per_sim_sec)
            .partial_cmp(&(!b.outcome.is_stable(), b.wall_secs_per_sim_sec))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut s = format!(
        "
At one step per frame (dt = {frame_dt:.3e} s), cheapest first:

| integrator | RMS error (m) | stable | energy dissipated (% of initial) | wall s per sim s |
|---|---:|---|---:|---:|
"
    );
    for row in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            row.integrator,
            fmt_num(row.rms_error_m),
            row.outcome.label().replace('|', "/"),
            if row.dissipated_pct.is_finite() {
                format!("{:.1}", row.dissipated_pct)
            } else {
                "—".to_owned()
            },
            fmt_num(row.wall_secs_per_sim_sec)
        );
    }
    s
}

/// Error levels the guidance table answers for, metres RMS.
const ERROR_LEVELS_M: [f64; 7] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7];

/// Costs within this share of the cheapest are a tie: timing noise on a busy machine is about
/// that large, and must not decide the answer.
pub const TIE_SHARE: f64 = 0.10;

/// For each error level, the cheapest of `items` that reached it, every one within
/// [`TIE_SHARE`] of the cheapest's cost included, in the items' own order: "which solver for
/// this accuracy, at what cost". `measure` gives an item's error (m) and cost, or `None` for
/// one that is no answer (diverged). `bench accuracy`'s guidance and `sweep report`'s table.
pub fn cheapest_per_level<T>(
    items: &[T],
    measure: impl Fn(&T) -> Option<(f64, f64)>,
) -> Vec<(f64, Vec<&T>)> {
    ERROR_LEVELS_M
        .iter()
        .map(|&level| {
            let reached: Vec<(&T, f64)> = items
                .iter()
                .filter_map(|item| {
                    let (error, cost) = measure(item)?;
                    (error <= level && cost.is_finite()).then_some((item, cost))
                })
                .collect();
            let least = reached
                .iter()
                .map(|&(_, cost)| cost)
                .fold(f64::INFINITY, f64::min);
            let tied = reached
                .into_iter()
                .filter(|&(_, cost)| cost <= least * (1.0 + TIE_SHARE))
                .map(|(item, _)| item)
                .collect();
            (level, tied)
        })
        .collect()
}

/// [`cheapest_per_level`] of a measurement's stable rows, by wall time per simulated second.
pub fn cheapest_rows(r: &Accuracy) -> Vec<(f64, Vec<&Row>)> {
    cheapest_per_level(&r.rows, |row| {
        row.outcome
            .is_stable()
            .then_some((row.rms_error_m, row.wall_secs_per_sim_sec))
    })
}

fn guidance(r: &Accuracy) -> String {
    let mut s = format!(
        "\n| RMS error at most | cheapest solver measured (within {:.0}% of each other: a tie) | dt (s) | wall s per sim s |\n|---:|---|---:|---:|\n",
        100.0 * TIE_SHARE
    );
    for (level, tied) in cheapest_rows(r) {
        if tied.is_empty() {
            let _ = writeln!(s, "| {level:.0e} m | none of the runs | — | — |");
            continue;
        }
        let join = |f: &dyn Fn(&Row) -> String| {
            tied.iter()
                .map(|row| f(row))
                .collect::<Vec<_>>()
                .join(" = ")
        };
        // A step above `check`'s estimate is said where it is recommended (Verlet at 8.3e-4 s on
        // the jello was recommended, above its estimated 4.27e-4 s, without a word).
        let above = |row: &Row| {
            r.stable
                .iter()
                .find(|st| st.integrator == row.integrator)
                .and_then(|st| st.estimate)
                .filter(|&limit| row.dt_secs > limit * (1.0 + 1e-6))
                .map(|limit| format!(" (above `check`'s estimated stable {limit:.3e} s)"))
                .unwrap_or_default()
        };
        let _ = writeln!(
            s,
            "| {level:.0e} m | {} | {} | {} |",
            join(&|row| format!("{}{}", row.integrator, above(row))),
            join(&|row| format!("{:.3e}", row.dt_secs)),
            join(&|row| fmt_num(row.wall_secs_per_sim_sec)),
        );
    }
    s
}

fn csv(r: &Accuracy) -> String {
    let mut s = String::from(
        "scene,integrator,dt_secs,steps,rms_error_m,max_error_m,energy_drift_j,stable,dissipated_pct,wall_secs_per_sim_sec,backend,at_estimate,status\n",
    );
    for row in &r.rows {
        let _ = writeln!(
            s,
            "{},{},{:e},{},{:e},{:e},{:e},{},{:e},{:e},\"{}\",{},{}",
            r.scene,
            row.integrator,
            row.dt_secs,
            row.steps,
            row.rms_error_m,
            row.max_error_m,
            row.energy_drift_j,
            row.outcome.is_stable(),
            row.dissipated_pct,
            row.wall_secs_per_sim_sec,
            row.backend,
            row.at_estimate,
            row.outcome.status()
        );
    }
    s
}

/// `dir` can hold the outputs: it is a folder, or can be made one.
pub fn check_out_dir(dir: &Path) -> Result<()> {
    let io = |source: std::io::Error| Error::WriteOutput {
        path: dir.to_owned(),
        source,
    };
    if dir.exists() && !dir.is_dir() {
        // create_dir_all says only "File exists" about a path that is not a folder.
        return Err(io(std::io::Error::other(
            "it exists and is not a folder: --out names a folder",
        )));
    }
    std::fs::create_dir_all(dir).map_err(io)
}

/// `accuracy-SCENE.md`, `.csv` and `.svg` (`chart`, the work-precision chart) in `dir`.
pub fn write_outputs(r: &Accuracy, chart: &str, dir: &Path) -> Result<()> {
    let io = |source: std::io::Error, p: &Path| Error::WriteOutput {
        path: p.to_owned(),
        source,
    };
    check_out_dir(dir)?;
    for (ext, text) in [
        ("md", markdown(r)),
        ("csv", csv(r)),
        ("svg", chart.to_owned()),
    ] {
        let p = dir.join(format!("accuracy-{}.{ext}", r.scene));
        std::fs::write(&p, text).map_err(|e| io(e, &p))?;
    }
    Ok(())
}

/// The same series in Rerun: per integrator, error and cost along the `dt_index` timeline
/// (0 = coarsest step).
pub fn record(r: &Accuracy, path: &Path) -> Result<()> {
    let rec = rerun::RecordingStreamBuilder::new("hooke-accuracy")
        .save(path)
        .map_err(|e| Error::rerun_while(format!("creating {}", path.display()), e))?;
    let err = |e: rerun::RecordingStreamError| Error::Rerun(e.into());
    for integrator in Integrator::ALL {
        for (k, row) in r
            .rows
            .iter()
            .filter(|p| p.integrator == integrator)
            .enumerate()
        {
            rec.set_time_sequence("dt_index", k as i64);
            if row.outcome.is_stable() {
                rec.log(
                    format!("accuracy/{integrator}/rms_error_m"),
                    &rerun::Scalars::single(row.rms_error_m),
                )
                .map_err(err)?;
                rec.log(
                    format!("accuracy/{integrator}/wall_secs_per_sim_sec"),
                    &rerun::Scalars::single(row.wall_secs_per_sim_sec),
                )
                .map_err(err)?;
                rec.log(
                    format!("accuracy/{integrator}/energy_drift_j"),
                    &rerun::Scalars::single(row.energy_drift_j),
                )
                .map_err(err)?;
            }
            rec.log(
                format!("accuracy/{integrator}/dt_secs"),
                &rerun::Scalars::single(row.dt_secs),
            )
            .map_err(err)?;
        }
    }
    rec.log_static(
        "accuracy/table",
        &rerun::TextDocument::from_markdown(markdown(r)),
    )
    .map_err(err)?;
    rec.flush_blocking().map_err(|e| Error::Rerun(e.into()))?;
    Ok(())
}
