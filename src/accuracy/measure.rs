//! The measurement itself: every integrator over a ladder of time steps against an f64 RK4
//! reference, and each integrator's largest stable step searched.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use crate::accuracy::reference::Reference;
use crate::backend::{self, BackendError, StopFlags};
use crate::error::{Error, Result};
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::run::prepare::{self, Request};
use crate::run::select::Device;
use crate::scene::settings::SettingsError;
use crate::state::{Snapshot, State};

use super::report;
use super::results::{Accuracy, Row, StableDt};
use super::stable_dt::{
    dissipated_pct, energy_scale, search_range, search_stable_dt, stayed_stable,
};

#[derive(Debug, Clone)]
pub struct AccuracyOptions {
    pub device: Device,
    /// Simulated time each run covers.
    pub duration_secs: f64,
    /// Time steps tried: the scene's dt × 2^k for k from `coarsest` down, `points` of them.
    pub points: u32,
    pub coarsest: i32,
    /// Also the fast end: doublings of the largest of those steps up to one step per frame
    /// (1/60 s at 60 frames/s), where only the unconditionally stable solvers survive.
    pub fast_end: bool,
    /// Timed runs of each point (at least 1); the wall time reported is their median.
    pub repeat: u32,
    pub out_dir: PathBuf,
    /// Also record the series to this .rrd file.
    pub rrd: Option<PathBuf>,
}

struct RunEnd {
    x: Vec<glam::Vec3>,
    balance_change_j: f64,
    wall_secs: f64,
}

/// What [`timed_runs`] leaves: the last run's end, and every run's wall time, in order.
pub struct Timed {
    /// The end as the recorder would see it (energies) and in full (positions, velocities).
    pub end: Snapshot,
    pub state: State,
    /// The energy balance at the start (J): its change is energy from nowhere.
    pub start_balance_j: f64,
    pub wall_secs: Vec<f64>,
    /// The backend as it describes itself.
    pub backend: String,
}

impl Timed {
    /// The median of the wall times.
    pub fn median_secs(&self) -> f64 {
        let mut t = self.wall_secs.clone();
        t.sort_by(f64::total_cmp);
        t.get(t.len() / 2).copied().unwrap_or(f64::NAN)
    }
}

/// Run `model` for `steps` steps of `step`, `repeat` times, each on a fresh backend watching
/// `stop` and timed (the wait for the device included). Each backend is deterministic, so the
/// runs end alike; only the clock differs between them. `bench accuracy` and a sweep's points
/// time their runs here.
pub fn timed_runs(
    model: &Arc<Model>,
    device: &Device,
    step: Step,
    steps: u64,
    repeat: u32,
    stop: &StopFlags,
) -> std::result::Result<Timed, BackendError> {
    let mut wall_secs = Vec::new();
    loop {
        let mut be = device.create(model.clone(), step)?;
        be.watch(stop.clone());
        let backend = be.describe();
        let start_balance_j = be.snapshot(0, Default::default())?.energies.balance_j();
        let start = Instant::now();
        backend::advance_steps(be.as_mut(), steps, 1000)?;
        be.finish()?;
        wall_secs.push(start.elapsed().as_secs_f64());
        if wall_secs.len() < repeat.max(1) as usize {
            continue;
        }
        return Ok(Timed {
            end: be.snapshot(1, Default::default())?,
            state: be.state()?,
            start_balance_j,
            wall_secs,
            backend,
        });
    }
}

/// `timed_runs` of `integrator` at `dt`: the end, and the backend's name.
fn run(
    model: &Arc<Model>,
    device: &Device,
    repeat: u32,
    integrator: Integrator,
    dt: f64,
    steps: u64,
) -> std::result::Result<(RunEnd, String), BackendError> {
    // XPBD at its default of one iteration per substep: the chart's dial is the substep.
    let t = timed_runs(
        model,
        device,
        Step::new(integrator, dt),
        steps,
        repeat,
        &StopFlags::default(),
    )?;
    Ok((
        RunEnd {
            balance_change_j: t.end.energies.balance_j() - t.start_balance_j,
            wall_secs: t.median_secs(),
            x: t.end.positions,
        },
        t.backend,
    ))
}

/// Measure `scene_arg`, telling `progress` what each stage finished (the whole takes minutes).
pub fn accuracy(
    scene_arg: &str,
    opts: &AccuracyOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Accuracy> {
    let planned = prepare::plan(&Request::named(scene_arg, opts.device.clone()), &mut |_| {})?;
    let (model, scene_dt) = (&planned.model, planned.settings.dt_secs);
    let duration = opts.duration_secs;
    if !(duration.is_finite() && duration > 0.0) {
        return Err(Error::Settings(SettingsError::Duration(duration)));
    }
    // Where the tables go is checked before the minutes of stepping, not after.
    report::check_out_dir(&opts.out_dir)?;
    let frame_dt = Some(1.0 / planned.settings.frame_rate_hz).filter(|_| opts.fast_end);
    let ladder: Vec<f64> = step_ladder(scene_dt, opts, frame_dt)
        .into_iter()
        // Whole steps that land on the duration.
        .map(|dt| duration / (duration / dt).round().max(1.0))
        .collect();
    let finest = ladder.iter().copied().fold(f64::INFINITY, f64::min);
    let reference_dt = finest / 4.0;
    let reference_x = {
        let mut reference = Reference::new(model.clone());
        reference.advance_to(duration, reference_dt);
        reference.x
    };
    progress(&format!("reference: f64 RK4 at dt = {reference_dt:.3e} s"));
    let mut rows = Vec::new();
    let supported = |i| supported(model, i);
    let estimates = crate::stability::stable_steps(
        &crate::stability::Modes::of(model),
        &crate::integrator::StepOptions::default(),
    );
    for integrator in Integrator::ALL.into_iter().filter(|&i| supported(i)) {
        let estimate = estimates
            .iter()
            .find(|s| s.integrator == integrator)
            .and_then(|s| s.finite_dt());
        let steps = ladder_to_estimate(&ladder, estimate, duration);
        for &(dt, at_estimate) in &steps {
            let mut r = row(model, opts, integrator, dt, &reference_x)?;
            r.at_estimate = at_estimate;
            rows.push(r);
        }
        progress(&format!("{integrator}: {} time steps", steps.len()));
    }
    let search_time = duration.min(0.5);
    let stable = estimates
        .into_iter()
        .filter(|s| supported(s.integrator))
        .map(|step| {
            let (integrator, estimate) = (step.integrator, step.dt_secs);
            // Where no step is stable for sure, search around the dashpots' line.
            let centre = step.finite_dt().or(step.dashpot_line_secs);
            let searched = search_range(integrator, centre.or(estimate), scene_dt);
            let found = search_stable_dt(model, integrator, searched, search_time);
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
        scene: planned.loaded.scene.name.clone(),
        duration_secs: duration,
        reference_dt_secs: reference_dt,
        // As the ladder rounded it to whole steps.
        frame_dt_secs: frame_dt
            .and(ladder.first().copied())
            .filter(|&top| top > scene_dt * 2f64.powi(opts.coarsest) * 1.01),
        rows,
        stable,
    };
    report::write_outputs(&result, &opts.out_dir)?;
    if let Some(path) = &opts.rrd {
        report::record(&result, path)?;
    }
    Ok(result)
}

/// The steps tried, largest first: the scene's dt × 2^k for k from `coarsest` down, and before
/// them, up to `frame_dt` when given, doublings of the largest and the frame's step itself.
pub fn step_ladder(scene_dt: f64, opts: &AccuracyOptions, frame_dt: Option<f64>) -> Vec<f64> {
    let top = scene_dt * 2f64.powi(opts.coarsest);
    let mut ladder = Vec::new();
    if let Some(frame_dt) = frame_dt.filter(|&f| f > top * 1.01) {
        ladder.push(frame_dt);
        let mut dt = top * 2.0;
        let mut faster = Vec::new();
        while dt < frame_dt / 1.01 {
            faster.push(dt);
            dt *= 2.0;
        }
        ladder.extend(faster.into_iter().rev());
    }
    ladder.extend((0..opts.points.max(2)).map(|k| top * 2f64.powi(-(k as i32))));
    ladder
}

/// The ladder, largest step first, with the integrator's estimated stable step `estimate` among
/// it (rounded down to whole steps over `duration`; `true` beside it) where no step of the
/// ladder lies within 2% of it and it is no finer than the ladder's finest, which the reference
/// is set from.
pub fn ladder_to_estimate(
    ladder: &[f64],
    estimate: Option<f64>,
    duration: f64,
) -> Vec<(f64, bool)> {
    let mut steps: Vec<(f64, bool)> = ladder.iter().map(|&dt| (dt, false)).collect();
    let finest = ladder.iter().copied().fold(f64::INFINITY, f64::min);
    if let Some(e) = estimate.filter(|e| e.is_finite() && *e > 0.0) {
        let at = duration / (duration / e).ceil().max(1.0);
        let near = ladder.iter().any(|&dt| (dt / at - 1.0).abs() < 0.02);
        if !near && at >= finest {
            steps.push((at, true));
            steps.sort_by(|a, b| b.0.total_cmp(&a.0));
        }
    }
    steps
}

/// An integrator that cannot simulate the scene's effects (validation refuses the pair) gets no
/// rows.
fn supported(model: &Model, integrator: Integrator) -> bool {
    integrator.supports(&model.effects).is_ok()
}

/// One run of `integrator` at `dt` over the whole duration, against its reference positions.
fn row(
    model: &Arc<Model>,
    opts: &AccuracyOptions,
    integrator: Integrator,
    dt: f64,
    reference_x: &[glam::DVec3],
) -> Result<Row> {
    let duration = opts.duration_secs;
    let steps = (duration / dt).round() as u64;
    Ok(
        match run(model, &opts.device, opts.repeat, integrator, dt, steps) {
            Ok((end, name)) => {
                let errors: Vec<f64> = end
                    .x
                    .iter()
                    .zip(reference_x)
                    .map(|(p, q)| (p.as_dvec3() - *q).length())
                    .collect();
                let rms =
                    (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
                let max = errors.iter().copied().fold(0.0, f64::max);
                Row {
                    integrator,
                    dt_secs: dt,
                    steps,
                    rms_error_m: rms,
                    max_error_m: max,
                    energy_drift_j: end.balance_change_j,
                    stable: rms.is_finite()
                        && stayed_stable(end.balance_change_j, energy_scale(model)),
                    dissipated_pct: dissipated_pct(end.balance_change_j, energy_scale(model)),
                    wall_secs_per_sim_sec: end.wall_secs / duration,
                    backend: name,
                    at_estimate: false,
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
                backend: format!("{:?}", opts.device.kind).to_lowercase(),
                at_estimate: false,
            },
            Err(e) => return Err(e.into()),
        },
    )
}
