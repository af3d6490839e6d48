//! `hooke bench accuracy` as a sweep: every supported integrator × the step ladder
//! ([`crate::accuracy::step_ladder`]) becomes a sweep's points, each against one f64 RK4
//! reference, so the runs go to either executor (this machine, or a Slurm job array) and every
//! point's result is kept as `result.json` like any sweep's. What stays here is what is not a
//! point: the plan, the reference computed once before the points, the search for each
//! integrator's largest stable step, and the tables.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::accuracy::{self, Accuracy, LadderOptions, Outcome, Row, StableDt};
use crate::error::{Error, Result};
use crate::integrator::Integrator;
use crate::model::Model;
use crate::run::prepare::{self, Request};
use crate::run::select::{BackendKind, Device};
use crate::scene::settings::SettingsError;
use crate::stability::StableStep;
use crate::sweep::file::{Key, Setting, SweepSpec};
use crate::sweep::plan::{Param, Plan, PlannedReference, ReferenceSolver};
use crate::sweep::result::{Load, PointResult, Status};
use crate::sweep::{Layout, plan, report};

#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    pub device: Device,
    /// Simulated time each run covers (whole frames of the scene's, the nearest).
    pub duration_secs: f64,
    pub ladder: LadderOptions,
    /// Timed runs of each short point (at least 1); its wall time is their median.
    pub repeat: u32,
    /// Where the tables go; the sweep's folder is made in it.
    pub out_dir: PathBuf,
    /// Also record the series to this .rrd file.
    pub rrd: Option<PathBuf>,
}

/// A point whose first timed run took this long (s) is timed once: the noise that repeats
/// cancel is a short run's, and a long one run three times would triple the chart's cost.
pub const REPEAT_UNDER_SECS: f64 = 1.0;

/// Points per reference step: the reference steps a quarter of the ladder's finest step.
const REFERENCE_DIVISOR: f64 = 4.0;

/// A `bench accuracy` planned as a sweep, with what its tables need besides the points.
pub struct AccuracySweep {
    pub plan: Plan,
    /// The sweep's folder: `OUT/accuracy-SCENE.sweep`.
    pub dir: PathBuf,
    /// Per point: its integrator, and whether its step is the integrator's estimate.
    rungs: Vec<(Integrator, bool)>,
    model: Arc<Model>,
    scene: String,
    scene_dt_secs: f64,
    duration_secs: f64,
    reference_dt_secs: f64,
    /// One step per frame, when the ladder reaches it.
    frame_dt_secs: Option<f64>,
    estimates: Vec<StableStep>,
}

/// Plan `scene_arg`'s measurement into `OUT/accuracy-SCENE.sweep` (a folder an earlier
/// measurement left there is replaced; any other is refused).
pub fn plan(scene_arg: &str, opts: &AccuracyOptions) -> Result<AccuracySweep> {
    let duration = opts.duration_secs;
    if !(duration.is_finite() && duration > 0.0) {
        return Err(Error::Settings(SettingsError::Duration(duration)));
    }
    let planned = prepare::plan(&Request::named(scene_arg, opts.device.clone()), &mut |_| {})?;
    // Where the tables go is checked before the minutes of stepping, not after.
    accuracy::check_out_dir(&opts.out_dir)?;
    let s = &planned.settings;
    let frame_secs = 1.0 / s.frame_rate_hz;
    let frames = (duration * s.frame_rate_hz).round().max(1.0);
    let ladder = accuracy::step_ladder(s.substeps, &opts.ladder);
    let finest = ladder.iter().copied().max().unwrap_or(1);
    let model = planned.model.clone();
    let estimates =
        crate::stability::stable_steps(&crate::stability::Modes::of(&model), &s.options);
    let backend = match opts.device.kind {
        BackendKind::Cpu => "cpu",
        BackendKind::Gpu => "gpu",
    };
    // The run's length, as the scene gives it (it may not give both).
    let length = match planned.loaded.scene.solver.frames {
        Some(_) => setting("solver.frames", toml::Value::Integer(frames as i64)),
        None => setting(
            "solver.duration_secs",
            toml::Value::Float(frames / s.frame_rate_hz),
        ),
    };
    let mut points = Vec::new();
    let mut rungs = Vec::new();
    for integrator in Integrator::ALL {
        if integrator.supports(&model.effects).is_err() {
            continue;
        }
        let estimate = estimates
            .iter()
            .find(|e| e.integrator == integrator)
            .and_then(|e| e.finite_dt());
        for (substeps, at_estimate) in accuracy::ladder_to_estimate(&ladder, estimate, frame_secs) {
            points.push(vec![
                setting("integrator", toml::Value::String(integrator.name().into())),
                setting("substeps", toml::Value::Integer(i64::from(substeps))),
            ]);
            rungs.push((integrator, at_estimate));
        }
    }
    let scene = match crate::scene::BUILT_IN.iter().any(|b| b.name == scene_arg) {
        true => scene_arg.to_owned(),
        false => std::fs::canonicalize(scene_arg)
            .map_or_else(|_| scene_arg.to_owned(), |p| p.display().to_string()),
    };
    let spec = SweepSpec {
        file: PathBuf::from(format!("bench accuracy {scene_arg}")),
        scene,
        repeat: Some(opts.repeat.max(1)),
        record: false,
        set: vec![
            setting("backend", toml::Value::String(backend.into())),
            length,
        ],
        points,
        varied: vec!["integrator".into(), "dt_secs".into()],
        reference: None,
    };
    let mut plan = plan::make(&spec).map_err(|e| Error::Sweep(e.to_string()))?;
    plan.repeat_under_secs = Some(REPEAT_UNDER_SECS);
    plan.adapter = opts.device.adapter.clone();
    plan.verify = opts.device.verify;
    let reference_dt = frame_secs / f64::from(finest) / REFERENCE_DIVISOR;
    // The reference ignores the solver section: one for all the points.
    let reference = plan.points.first().map(|p| {
        PlannedReference::new(
            ReferenceSolver::F64Rk4 {
                dt_secs: reference_dt,
            },
            p.scene_toml.clone(),
        )
    });
    for p in &mut plan.points {
        p.reference = reference.clone();
        // The label says the step, not the substeps that give it.
        if let Some(n) = p.params.iter_mut().find(|q| q.name == "substeps") {
            let dt = n.value.parse::<f64>().map_or(f64::NAN, |n| frame_secs / n);
            *n = Param {
                name: "dt_secs".into(),
                value: format!("{dt:.3e}"),
            };
        }
    }
    let dir = opts
        .out_dir
        .join(format!("accuracy-{}.sweep", planned.loaded.scene.name));
    replace_earlier(&dir)?;
    plan::start(&plan, &dir)?;
    Ok(AccuracySweep {
        plan,
        dir,
        rungs,
        model,
        scene: planned.loaded.scene.name.clone(),
        scene_dt_secs: s.dt_secs,
        duration_secs: frames / s.frame_rate_hz,
        reference_dt_secs: reference_dt,
        frame_dt_secs: ladder.contains(&1).then_some(frame_secs),
        estimates,
    })
}

fn setting(name: &str, value: toml::Value) -> Setting {
    let key = match name {
        "integrator" => Key::Integrator,
        "substeps" => Key::Substeps,
        "backend" => Key::Backend,
        path => Key::Scene(path.to_owned()),
    };
    Setting {
        name: name.to_owned(),
        key,
        value,
        at: None,
    }
}

/// An earlier measurement's folder is replaced: its points were of another build or
/// another ladder. A folder without a plan is not ours to remove.
fn replace_earlier(dir: &std::path::Path) -> Result<()> {
    if !dir.exists() {
        return Ok(());
    }
    if !Layout::new(dir).plan().exists() {
        return Err(Error::Sweep(format!(
            "{} exists and is not a sweep's folder: move it, or give another --out",
            dir.display()
        )));
    }
    std::fs::remove_dir_all(dir)
        .map_err(|e| Error::Sweep(format!("cannot replace {}: {e}", dir.display())))
}

/// The f64 RK4 reference, computed before the points (which would otherwise each compute it
/// at once): `false` when `cancel` stopped it.
pub fn reference(sweep: &AccuracySweep, cancel: &Arc<AtomicBool>) -> Result<bool> {
    let all: Vec<usize> = (0..sweep.plan.points.len()).collect();
    crate::sweep::reference::prepare_all(&sweep.plan, &Layout::new(&sweep.dir), &all, cancel)
}

impl AccuracySweep {
    pub fn reference_dt_secs(&self) -> f64 {
        self.reference_dt_secs
    }
}

/// The measurement from the points' results, with each integrator's largest stable step
/// searched (here, on this machine), written to `opts.out_dir` with the sweep's report in its
/// folder; `progress` hears what each search found.
pub fn finish(
    sweep: &AccuracySweep,
    opts: &AccuracyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Accuracy> {
    let results = report::results(&sweep.dir, &sweep.plan);
    let scale = accuracy::energy_scale(&sweep.model);
    let mut rows = Vec::new();
    for (point, &(integrator, at_estimate)) in sweep.plan.points.iter().zip(&sweep.rungs) {
        let Some(r) = results.iter().find(|r| r.index == point.index) else {
            return Err(Error::Sweep(format!(
                "point {} ({}) of {} has no result: `hooke sweep resume {}` runs it",
                point.index,
                point.label(),
                sweep.dir.display(),
                sweep.dir.display()
            )));
        };
        rows.push(row(r, integrator, at_estimate, sweep.duration_secs, scale));
    }
    let search_time = sweep.duration_secs.min(0.5);
    let stable = sweep
        .estimates
        .iter()
        .filter(|s| sweep.rungs.iter().any(|&(i, _)| i == s.integrator))
        .map(|step| {
            let (integrator, estimate) = (step.integrator, step.dt_secs);
            // Where no step is stable for sure, search around the dashpots' line.
            let centre = step.finite_dt().or(step.dashpot_line_secs);
            let searched =
                accuracy::search_range(integrator, centre.or(estimate), sweep.scene_dt_secs);
            let found = accuracy::search_stable_dt(&sweep.model, integrator, searched, search_time);
            progress(&format!("{integrator}: largest stable dt searched"));
            StableDt {
                integrator,
                estimate,
                found,
                searched,
            }
        })
        .collect();
    let result = Accuracy {
        scene: sweep.scene.clone(),
        duration_secs: sweep.duration_secs,
        reference_dt_secs: sweep.reference_dt_secs,
        frame_dt_secs: sweep.frame_dt_secs,
        rows,
        stable,
        repeats: sweep.plan.repeats(),
        timed_alone: results.iter().all(|r| r.load == Load::Alone),
    };
    let mut chart = report::chart(&sweep.plan, &results);
    chart.title = format!(
        "What accuracy costs: {} ({} s simulated)",
        result.scene, result.duration_secs
    );
    accuracy::write_outputs(&result, &accuracy::chart::svg(&chart), &opts.out_dir)?;
    report::write(&sweep.dir, &sweep.plan, &sweep.dir)?;
    if let Some(path) = &opts.rrd {
        accuracy::record(&result, path)?;
    }
    Ok(result)
}

/// A point's result as a row of the table.
fn row(
    r: &PointResult,
    integrator: Integrator,
    at_estimate: bool,
    duration: f64,
    scale: f64,
) -> Row {
    let drift = r.energies.map_or(f64::NAN, |e| e.balance_change_j);
    let rms = r.error_rms_m.unwrap_or(f64::NAN);
    // The table has room for the reason's first sentence; result.json keeps the whole message.
    let why = || r.first_sentence().unwrap_or("no reason given").to_owned();
    let outcome = match r.status {
        Status::Ok if rms.is_finite() => Outcome::Stable,
        Status::Ok => Outcome::Failed("no error against the reference".to_owned()),
        Status::Diverged => Outcome::Diverged,
        Status::Refused => Outcome::Refused(why()),
        Status::Failed => Outcome::Failed(why()),
    };
    Row {
        integrator,
        dt_secs: r.dt_secs.unwrap_or(f64::NAN),
        steps: r.steps.unwrap_or(0),
        rms_error_m: rms,
        max_error_m: r.error_max_m.unwrap_or(f64::NAN),
        energy_drift_j: drift,
        outcome,
        dissipated_pct: accuracy::dissipated_pct(drift, scale),
        wall_secs_per_sim_sec: r.wall_secs.map_or(f64::NAN, |w| w / duration),
        backend: r.backend.clone().unwrap_or_default(),
        at_estimate,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point the run refused (or that failed) is no instability: its row says which it was
    /// and why, where it used to read "diverged".
    #[test]
    fn a_refused_point_reads_as_refused_with_its_reason() {
        let result = |status: &str, message: &str| -> PointResult {
            serde_json::from_value(serde_json::json!({
                "index": 3, "label": "dt_secs=0.1", "params": [], "status": status,
                "message": message, "notes": [], "wall_secs_each": [], "load": "alone",
                "host": "here",
            }))
            .expect("a result.json of a point that did not run")
        };
        let integrator = Integrator::ALL[0];
        let refused = result("refused", "The step is refused here. Use a smaller one.");
        let outcome = row_of(&refused, integrator);
        assert_eq!(
            outcome,
            Outcome::Refused("The step is refused here".to_owned())
        );
        assert_eq!(outcome.label(), "refused: The step is refused here");
        assert!(!outcome.is_stable());
        let failed = row_of(&result("failed", "no adapter"), integrator);
        assert_eq!(failed.label(), "failed: no adapter");
        let diverged = row_of(
            &result("diverged", "diverged at frame 3. Try less."),
            integrator,
        );
        assert_eq!(diverged, Outcome::Diverged);
    }

    fn row_of(r: &PointResult, integrator: Integrator) -> Outcome {
        row(r, integrator, false, 1.0, 1.0).outcome
    }
}
