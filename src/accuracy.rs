//! `hooke bench accuracy`: what accuracy costs in time. Every integrator over a ladder of time
//! steps against an f64 RK4 reference: position error, energy drift, stability and wall time per
//! simulated second; each integrator's largest stable dt found by search beside the estimate that
//! `hooke check` gives. Written as Markdown, CSV and an SVG work-precision chart.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::backend::{self, BackendError};
use crate::error::{Error, Result};
use crate::integrator::Integrator;
use crate::model::{self, Model};
use crate::reference::Reference;
use crate::select::{self, BackendKind};
use crate::settings::{Overrides, Settings, SettingsError};

#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    pub backend: BackendKind,
    pub adapter: Option<String>,
    /// Simulated time each run covers.
    pub duration_secs: f64,
    /// Time steps tried: the scene's dt × 2^k for k from `coarsest` down, `points` of them.
    pub points: u32,
    pub coarsest: i32,
    pub out_dir: PathBuf,
    /// Also record the series to this .rrd file.
    pub rrd: Option<PathBuf>,
}

#[derive(Debug, Clone)]
pub struct Row {
    pub integrator: Integrator,
    pub dt_secs: f64,
    pub steps: u64,
    /// RMS and largest distance from the reference at the end (NaN when unstable).
    pub rms_error_m: f64,
    pub max_error_m: f64,
    /// Change of (mechanical + dissipated − collider work) over the run.
    pub energy_drift_j: f64,
    /// Did not diverge: stayed finite and below the runaway speed, and gained less than 10% of
    /// the initial mechanical energy. A run that loses energy the ledger does not count (the
    /// numerical damping of implicit Euler) is stable; `dissipated_pct` says how much it lost.
    pub stable: bool,
    /// Energy lost beyond what the ledger counts, as a percentage of the initial mechanical
    /// energy (0 when the balance held or grew).
    pub dissipated_pct: f64,
    pub wall_secs_per_sim_sec: f64,
    /// Where the run happened.
    pub backend: String,
}

#[derive(Debug, Clone)]
pub struct StableDt {
    pub integrator: Integrator,
    pub estimate: Option<f64>,
    pub found: Found,
    /// The steps searched, smallest and largest.
    pub searched: (f64, f64),
}

/// What the search for the largest stable dt found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Found {
    /// Stable at this dt, unstable at the next one tried.
    Largest(f64),
    /// Stable at the largest dt tried: the true limit is at least this.
    AtLeast(f64),
    /// Unstable even at the smallest dt tried.
    Unstable,
}

impl Found {
    /// The largest dt known to be stable.
    pub fn dt(&self) -> Option<f64> {
        match *self {
            Found::Largest(dt) | Found::AtLeast(dt) => Some(dt),
            Found::Unstable => None,
        }
    }
}

/// Implicit Euler is searched from the scene's dt up to at least this (one step per 10 frames
/// at 60 Hz): where users take it.
pub const IMPLICIT_SEARCH_UP_TO_SECS: f64 = 0.1;

#[derive(Debug, Clone)]
pub struct Accuracy {
    pub scene: String,
    pub duration_secs: f64,
    pub reference_dt_secs: f64,
    pub rows: Vec<Row>,
    pub stable: Vec<StableDt>,
}

struct RunEnd {
    x: Vec<glam::Vec3>,
    balance_change_j: f64,
    wall_secs: f64,
}

/// Run `model` for `steps` steps of `dt` and time it (the wait for the device included).
fn run(
    model: &Arc<Model>,
    kind: BackendKind,
    adapter: Option<&str>,
    integrator: Integrator,
    dt: f64,
    steps: u64,
) -> std::result::Result<(RunEnd, String), BackendError> {
    let mut be = select::create(kind, model.clone(), integrator, dt, adapter)?;
    let name = be.describe();
    let b0 = be.snapshot(0, Default::default())?.energies.balance_j();
    let start = Instant::now();
    backend::advance_steps(be.as_mut(), steps, 1000)?;
    be.finish()?;
    let wall_secs = start.elapsed().as_secs_f64();
    let end = be.snapshot(1, Default::default())?;
    Ok((
        RunEnd {
            x: end.positions,
            balance_change_j: end.energies.balance_j() - b0,
            wall_secs,
        },
        name,
    ))
}

/// The energy against which a run's balance drift is judged: the initial mechanical energy.
fn energy_scale(model: &Model) -> f64 {
    let e0 = crate::cpu::compute_energies(model, &model.springs, &model.initial);
    e0.total_j().abs().max(e0.kinetic_j).max(1e-6)
}

/// Stable: stays finite, and gains less than a tenth of the initial mechanical energy (a weakly
/// unstable scheme grows without ever overflowing in a short run). Losing energy is not
/// instability: a damped, bounded run is stable, and its loss is reported apart.
fn stayed_stable(balance_change_j: f64, scale: f64) -> bool {
    balance_change_j.is_finite() && balance_change_j < 0.1 * scale
}

/// Energy lost beyond the ledger, in percent of `scale`.
fn dissipated_pct(balance_change_j: f64, scale: f64) -> f64 {
    if balance_change_j.is_finite() {
        100.0 * (-balance_change_j).max(0.0) / scale
    } else {
        f64::NAN
    }
}

/// Whether `integrator` at `dt` runs `duration` on the CPU without diverging (see
/// [`stayed_stable`]).
pub fn is_stable(model: &Arc<Model>, integrator: Integrator, dt: f64, duration: f64) -> bool {
    let steps = (duration / dt).ceil() as u64;
    let mut be = crate::cpu::CpuBackend::new(model.clone(), integrator, dt);
    run_cpu(&mut be, steps).is_ok_and(|change| stayed_stable(change, energy_scale(model)))
}

fn run_cpu(be: &mut crate::cpu::CpuBackend, steps: u64) -> std::result::Result<f64, BackendError> {
    use crate::backend::Backend as _;
    let b0 = be.snapshot(0, Default::default())?.energies.balance_j();
    backend::advance_steps(be, steps, 10_000)?;
    Ok(be.snapshot(0, Default::default())?.energies.balance_j() - b0)
}

/// Bisection (in log dt) between a stable and an unstable step within `[lo, hi]`.
pub fn search_stable_dt(
    model: &Arc<Model>,
    integrator: Integrator,
    (mut lo, mut hi): (f64, f64),
    duration: f64,
) -> Found {
    if !is_stable(model, integrator, lo, duration) {
        return Found::Unstable;
    }
    if is_stable(model, integrator, hi, duration) {
        return Found::AtLeast(hi);
    }
    for _ in 0..10 {
        let mid = (lo * hi).sqrt();
        if is_stable(model, integrator, mid, duration) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Found::Largest(lo)
}

/// Where to search each integrator's largest stable dt: 16× either side of the estimate (of
/// the scene's dt where there is none); implicit Euler from the scene's dt to at least
/// [`IMPLICIT_SEARCH_UP_TO_SECS`], in whole doublings.
pub fn search_range(integrator: Integrator, estimate: Option<f64>, scene_dt: f64) -> (f64, f64) {
    match (integrator, estimate) {
        (Integrator::Implicit, _) => {
            let doublings = (IMPLICIT_SEARCH_UP_TO_SECS / scene_dt)
                .log2()
                .ceil()
                .max(0.0);
            (scene_dt, scene_dt * 2f64.powf(doublings))
        }
        (_, Some(e)) if e.is_finite() => (e / 16.0, e * 16.0),
        _ => (scene_dt / 16.0, scene_dt * 16.0),
    }
}

pub fn accuracy(scene_arg: &str, opts: &AccuracyOptions) -> Result<Accuracy> {
    let loaded = crate::scene::load(scene_arg)?;
    let settings = Settings::resolve(&loaded.scene, &Overrides::default())?;
    let model = Arc::new(model::build(&loaded.scene));
    let duration = opts.duration_secs;
    if !(duration.is_finite() && duration > 0.0) {
        return Err(Error::Settings(SettingsError(format!(
            "--duration must be a positive number of seconds, got {duration}"
        ))));
    }
    let ladder: Vec<f64> = (0..opts.points.max(2))
        .map(|k| {
            let dt = settings.dt_secs * 2f64.powi(opts.coarsest - k as i32);
            // Whole steps that land on the duration.
            duration / (duration / dt).round().max(1.0)
        })
        .collect();
    let finest = ladder.iter().copied().fold(f64::INFINITY, f64::min);
    let reference_dt = finest / 4.0;
    // One reference per step size: friction's stick limit depends on the dt being judged.
    let references: Vec<Vec<glam::DVec3>> = ladder
        .iter()
        .map(|&dt| {
            let mut reference = Reference::new(model.clone());
            reference.advance_to(duration, reference_dt, dt);
            reference.x
        })
        .collect();
    let mut rows = Vec::new();
    // Implicit Euler has no mass–mass contact (validation refuses the pair): no rows for it.
    let supported =
        |i: Integrator| !(i == Integrator::Implicit && model.effects.self_collision.is_some());
    for integrator in Integrator::ALL.into_iter().filter(|&i| supported(i)) {
        for (&dt, reference_x) in ladder.iter().zip(&references) {
            let steps = (duration / dt).round() as u64;
            let row = match run(
                &model,
                opts.backend,
                opts.adapter.as_deref(),
                integrator,
                dt,
                steps,
            ) {
                Ok((end, name)) => {
                    let errors: Vec<f64> = end
                        .x
                        .iter()
                        .zip(reference_x)
                        .map(|(p, q)| (p.as_dvec3() - *q).length())
                        .collect();
                    let rms = (errors.iter().map(|e| e * e).sum::<f64>()
                        / errors.len().max(1) as f64)
                        .sqrt();
                    let max = errors.iter().copied().fold(0.0, f64::max);
                    Row {
                        integrator,
                        dt_secs: dt,
                        steps,
                        rms_error_m: rms,
                        max_error_m: max,
                        energy_drift_j: end.balance_change_j,
                        stable: rms.is_finite()
                            && stayed_stable(end.balance_change_j, energy_scale(&model)),
                        dissipated_pct: dissipated_pct(end.balance_change_j, energy_scale(&model)),
                        wall_secs_per_sim_sec: end.wall_secs / duration,
                        backend: name,
                    }
                }
                Err(BackendError::Diverged(_)) => Row {
                    integrator,
                    dt_secs: dt,
                    steps,
                    rms_error_m: f64::NAN,
                    max_error_m: f64::NAN,
                    energy_drift_j: f64::NAN,
                    stable: false,
                    dissipated_pct: f64::NAN,
                    wall_secs_per_sim_sec: f64::NAN,
                    backend: format!("{:?}", opts.backend).to_lowercase(),
                },
                Err(e) => return Err(e.into()),
            };
            rows.push(row);
        }
    }
    let search_time = duration.min(0.5);
    let stable = crate::stability::stable_dts(&model)
        .into_iter()
        .filter(|(i, _)| supported(*i))
        .map(|(integrator, estimate)| {
            let searched = search_range(integrator, estimate, settings.dt_secs);
            StableDt {
                integrator,
                estimate,
                found: search_stable_dt(&model, integrator, searched, search_time),
                searched,
            }
        })
        .collect();
    let report = Accuracy {
        scene: loaded.scene.name.clone(),
        duration_secs: duration,
        reference_dt_secs: reference_dt,
        rows,
        stable,
    };
    write_outputs(&report, &opts.out_dir)?;
    if let Some(path) = &opts.rrd {
        record(&report, path)?;
    }
    Ok(report)
}

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
        "Scene `{}`, {} s simulated, against f64 RK4 at dt = {:.3e} s.\n",
        r.scene, r.duration_secs, r.reference_dt_secs
    );
    let _ = writeln!(
        s,
        "| integrator | dt (s) | steps | RMS error (m) | max error (m) | energy drift (J) | stable | energy dissipated (% of initial) | wall s per sim s | backend |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---|---:|---:|---|");
    for row in &r.rows {
        let _ = writeln!(
            s,
            "| {} | {:.3e} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.integrator,
            row.dt_secs,
            row.steps,
            fmt_num(row.rms_error_m),
            fmt_num(row.max_error_m),
            fmt_num(row.energy_drift_j),
            if row.stable { "yes" } else { "diverged" },
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
            None => "none (unstable even at ωdt = 0.01)".to_owned(),
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
    s
}

/// Error levels the guidance table answers for, metres RMS.
const ERROR_LEVELS_M: [f64; 6] = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7];

/// For each error level, the cheapest run (least wall time per simulated second) that stayed
/// stable and reached it: "which solver for this accuracy, at what cost".
pub fn cheapest_per_level(r: &Accuracy) -> Vec<(f64, Option<&Row>)> {
    ERROR_LEVELS_M
        .iter()
        .map(|&level| {
            let best = r
                .rows
                .iter()
                .filter(|row| row.stable && row.rms_error_m <= level)
                .min_by(|a, b| a.wall_secs_per_sim_sec.total_cmp(&b.wall_secs_per_sim_sec));
            (level, best)
        })
        .collect()
}

fn guidance(r: &Accuracy) -> String {
    let mut s = String::from(
        "\n| RMS error at most | cheapest solver measured | dt (s) | wall s per sim s |\n|---:|---|---:|---:|\n",
    );
    for (level, best) in cheapest_per_level(r) {
        let _ = match best {
            Some(row) => writeln!(
                s,
                "| {level:.0e} m | {} | {:.3e} | {} |",
                row.integrator,
                row.dt_secs,
                fmt_num(row.wall_secs_per_sim_sec)
            ),
            None => writeln!(s, "| {level:.0e} m | none of the runs | — | — |"),
        };
    }
    s
}

fn csv(r: &Accuracy) -> String {
    let mut s = String::from(
        "scene,integrator,dt_secs,steps,rms_error_m,max_error_m,energy_drift_j,stable,dissipated_pct,wall_secs_per_sim_sec,backend\n",
    );
    for row in &r.rows {
        let _ = writeln!(
            s,
            "{},{},{:e},{},{:e},{:e},{:e},{},{:e},{:e},\"{}\"",
            r.scene,
            row.integrator,
            row.dt_secs,
            row.steps,
            row.rms_error_m,
            row.max_error_m,
            row.energy_drift_j,
            row.stable,
            row.dissipated_pct,
            row.wall_secs_per_sim_sec,
            row.backend
        );
    }
    s
}

const COLORS: [&str; 6] = [
    "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf",
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
    let px = |v: f64| ml + (lx(v) - x0) / (x1 - x0) * (w - ml - mr);
    let py = |v: f64| h - mb - (lx(v) - y0) / (y1 - y0) * (h - mt - mb);
    let mut s = String::new();
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
    for (k, integrator) in Integrator::ALL.iter().enumerate() {
        let c = COLORS[k % COLORS.len()];
        let line: Vec<(f64, f64)> = r
            .rows
            .iter()
            .filter(|p| p.integrator == *integrator && p.stable && p.rms_error_m > 0.0)
            .map(|p| (px(p.wall_secs_per_sim_sec.max(1e-9)), py(p.rms_error_m)))
            .collect();
        let path: Vec<String> = line.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
            path.join(" ")
        );
        for (x, y) in &line {
            let _ = writeln!(s, r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{c}"/>"#);
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
        mt + 20.0 + 22.0 * 6.0 + 10.0
    );
    s.push_str("</svg>\n");
    s
}

fn write_outputs(r: &Accuracy, dir: &Path) -> Result<()> {
    let io = |e: std::io::Error, p: &Path| {
        Error::Settings(SettingsError(format!("cannot write {}: {e}", p.display())))
    };
    std::fs::create_dir_all(dir).map_err(|e| io(e, dir))?;
    for (ext, text) in [("md", markdown(r)), ("csv", csv(r)), ("svg", svg(r))] {
        let p = dir.join(format!("accuracy-{}.{ext}", r.scene));
        std::fs::write(&p, text).map_err(|e| io(e, &p))?;
    }
    Ok(())
}

/// The same series in Rerun: per integrator, error and cost along the `dt_index` timeline
/// (0 = coarsest step).
fn record(r: &Accuracy, path: &Path) -> Result<()> {
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
            if row.stable {
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
