//! One point of a sweep, run from the plan alone (`hooke sweep point DIR N`, which both
//! executors start): its recording as `hooke run --save` makes it, with the point's parameters
//! and results as the recording's properties; then its timed runs, stepping only; then its
//! `result.json`, last and atomically. A point killed on the way leaves no result, and its next
//! run starts it afresh.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::backend::{BackendError, StopFlags};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::run::prepare;
use crate::scene::settings::Settings;

use super::plan::{self, Layout, Plan, PlannedPoint, request};
use super::properties;
use super::reference;
use super::result::{EndEnergies, Load, PointResult, Status};

/// Run point `index` of the sweep in `dir`, unless it is done already: its result either way,
/// or `Ok(None)` when `cancel` stopped it (nothing of it is kept as a result).
pub fn run_point(
    dir: &Path,
    index: usize,
    load: Load,
    cancel: &Arc<AtomicBool>,
) -> Result<Option<PointResult>> {
    let plan = plan::read(dir)?;
    let layout = Layout::new(dir);
    let Some(point) = plan.points.get(index) else {
        return Err(Error::Sweep(format!(
            "the sweep in {} has {} points, numbered 0 to {}; there is no point {index}",
            dir.display(),
            plan.points.len(),
            plan.points.len().saturating_sub(1)
        )));
    };
    let result_path = layout.result(index);
    if let Some(done) = super::result::read(&result_path).filter(|r| r.status != Status::Failed) {
        return Ok(Some(done));
    }
    let folder = layout.point(index);
    let io = |what: &str, e: std::io::Error| {
        Error::Sweep(format!(
            "point {index}: {what} in {}: {e}",
            folder.display()
        ))
    };
    std::fs::create_dir_all(&folder).map_err(|e| io("cannot make its folder", e))?;
    std::fs::write(folder.join("scene.toml"), &point.scene_toml)
        .map_err(|e| io("cannot write scene.toml", e))?;
    let _held = Held::new(&folder);
    let mut result = blank(point, load);
    let ended = run(&plan, &layout, point, &mut result, cancel)?;
    if !ended {
        return Ok(None);
    }
    plan::write_json_atomic(&result_path, &result)
        .map_err(|e| io("cannot write result.json", e))?;
    Ok(Some(result))
}

/// The point's `running` file, naming the process that holds it (`sweep status` reads it),
/// gone when the point is.
struct Held(std::path::PathBuf);

impl Held {
    fn new(folder: &Path) -> Self {
        let path = folder.join("running");
        let _ = std::fs::write(
            &path,
            format!("{} {}\n", std::process::id(), super::result::host()),
        );
        Self(path)
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn blank(point: &PlannedPoint, load: Load) -> PointResult {
    PointResult {
        index: point.index,
        label: point.label(),
        params: point.params.clone(),
        status: Status::Failed,
        message: None,
        notes: Vec::new(),
        backend: None,
        integrator: None,
        dt_secs: None,
        substeps: None,
        frames: None,
        steps: None,
        masses: None,
        stable_dt_secs: None,
        wall_secs: None,
        wall_secs_each: Vec::new(),
        load,
        steps_per_sec: None,
        energies: None,
        error_rms_m: None,
        error_max_m: None,
        digest: None,
        recording: None,
        host: super::result::host(),
    }
}

/// Fill `result`: `false` when `cancel` stopped the point.
fn run(
    plan: &Plan,
    layout: &Layout,
    point: &PlannedPoint,
    result: &mut PointResult,
    cancel: &Arc<AtomicBool>,
) -> Result<bool> {
    let request = request(plan, &point.scene_toml, &point.backend)?;
    let mut notes = Vec::new();
    let mut say = |n: prepare::Notice| notes.push(n.to_string());
    // A point that is not recorded opens no backend here: its timed runs open their own.
    let made = match plan.record {
        true => prepare::prepare(&request, &mut say).map(Made::ToRecord),
        false => prepare::plan(&request, &mut say).map(Made::ToTime),
    };
    result.notes = notes;
    let made = match made {
        Ok(m) => m,
        Err(e) => {
            result.status = match e {
                Error::Settings(_) | Error::Scene(_) | Error::Buried(_) => Status::Refused,
                Error::BelowResolution(_) | Error::TooLarge(_) => Status::Refused,
                _ => Status::Failed,
            };
            result.message = Some(e.to_string());
            return Ok(true);
        }
    };
    let prepared = match made {
        Made::ToTime(p) => {
            describe(result, &p.model, &p.settings, &point.backend);
            return measure(plan, layout, point, result, &p.model, &p.settings, cancel);
        }
        Made::ToRecord(p) => p,
    };
    let (model, settings) = (prepared.model.clone(), prepared.settings.clone());
    describe(result, &model, &settings, &prepared.backend.describe());
    let (recording, ran) = record(plan, layout, point, result, prepared, cancel)?;
    let ended = match ran {
        Recorded::Cancelled => false,
        Recorded::Diverged | Recorded::Failed => true,
        Recorded::Ran => measure(plan, layout, point, result, &model, &settings, cancel)?,
    };
    recording.end(ended.then_some(&*result))?;
    Ok(ended)
}

/// A point made ready: to record (its backend open), or only to time.
enum Made {
    ToRecord(prepare::Prepared),
    ToTime(prepare::Planned),
}

/// How a point's recorded run ended.
enum Recorded {
    Ran,
    /// A result already: diverged, or failed, with its message.
    Diverged,
    Failed,
    Cancelled,
}

/// The recorded run, exactly as `hooke run --save` makes it, into the point's `.rrd`.
fn record(
    plan: &Plan,
    layout: &Layout,
    point: &PlannedPoint,
    result: &mut PointResult,
    prepared: prepare::Prepared,
    cancel: &Arc<AtomicBool>,
) -> Result<(properties::PointRecording, Recorded)> {
    let rrd = layout.recording(point.index);
    result.recording = rrd
        .strip_prefix(&layout.dir)
        .ok()
        .map(|p| p.to_string_lossy().into_owned());
    let recording = properties::open(plan, point, &rrd)?;
    let record = crate::record::RecordOptions::default().for_scene(&prepared.loaded.scene);
    let mut opts = crate::run::RunOptions::unattended(None);
    opts.record = record;
    let ran = match crate::run::run(prepared, recording.rec.clone(), &opts, cancel.clone()) {
        Ok(summary) if summary.cancelled => Recorded::Cancelled,
        // A run that went on past a warning is a result the user must be told about with it.
        Ok(summary) => {
            result.notes.extend(summary.notes);
            Recorded::Ran
        }
        Err(Error::Backend(e)) => {
            result.status = Status::Diverged;
            result.message = Some(e.to_string());
            Recorded::Diverged
        }
        Err(e) => {
            result.status = Status::Failed;
            result.message = Some(e.to_string());
            Recorded::Failed
        }
    };
    Ok((recording, ran))
}

/// The timed runs, then the error against the reference: `false` when `cancel` stopped them.
fn measure(
    plan: &Plan,
    layout: &Layout,
    point: &PlannedPoint,
    result: &mut PointResult,
    model: &Arc<Model>,
    settings: &Settings,
    cancel: &Arc<AtomicBool>,
) -> Result<bool> {
    let TimedEnd::Ended(end) = timed(plan, point, result, model, settings, cancel)? else {
        return Ok(false);
    };
    if let (Some(r), Some(end)) = (&point.reference, end) {
        let Some(reference) = reference::end(plan, layout, r, cancel)? else {
            return Ok(false);
        };
        let gap = reference::gap(&reference, &end)?;
        result.error_rms_m = Some(gap.rms_m);
        result.error_max_m = Some(gap.max_m);
    }
    Ok(true)
}

/// How the timed runs ended.
enum TimedEnd {
    /// With the end positions, where they got there.
    Ended(Option<Vec<glam::Vec3>>),
    Cancelled,
}

fn describe(result: &mut PointResult, model: &Model, settings: &Settings, backend: &str) {
    let steps = settings.frames * u64::from(settings.substeps);
    result.backend = Some(backend.to_owned());
    result.integrator = Some(settings.integrator.name().to_owned());
    result.dt_secs = Some(settings.dt_secs);
    result.substeps = Some(settings.substeps);
    result.frames = Some(settings.frames);
    result.steps = Some(steps);
    result.masses = Some(model.mass_count());
    result.stable_dt_secs = crate::stability::stable_step_with(
        &crate::stability::Modes::of(model),
        settings.integrator,
        &settings.options,
    )
    .finite_dt();
}

/// The timed runs, each on a fresh backend, stepping only: the median time, the end state's
/// digest and energies, and the end positions.
fn timed(
    plan: &Plan,
    point: &PlannedPoint,
    result: &mut PointResult,
    model: &Arc<Model>,
    settings: &Settings,
    cancel: &Arc<AtomicBool>,
) -> Result<TimedEnd> {
    let steps = settings.frames * u64::from(settings.substeps);
    let runs = crate::accuracy::timed_runs(
        model,
        &plan.device(&point.backend),
        settings.step(),
        steps,
        plan.repeats(),
        &StopFlags::new([cancel.clone()]),
    );
    if cancel.load(Ordering::SeqCst) {
        return Ok(TimedEnd::Cancelled);
    }
    let t = match runs {
        Ok(t) => t,
        Err(e @ (BackendError::Device(_) | BackendError::Internal(_))) => return Err(e.into()),
        Err(e) => {
            // The recorded run got through, so this is the same divergence only if the
            // backend is not deterministic: say what happened all the same.
            result.status = Status::Diverged;
            result.message = Some(format!("a timed run: {e}"));
            return Ok(TimedEnd::Ended(None));
        }
    };
    let e = t.end.energies;
    result.energies = Some(EndEnergies {
        kinetic_j: e.kinetic_j,
        elastic_j: e.elastic_j,
        gravity_j: e.gravity_j,
        contact_j: e.contact_j,
        balance_j: e.balance_j(),
        balance_change_j: e.balance_j() - t.start_balance_j,
    });
    result.digest = Some(format!("{:016x}", t.state.digest()));
    // As the backend describes itself (a point not recorded had only "cpu" or "gpu" so far).
    result.backend = Some(t.backend.clone());
    let median = t.median_secs();
    result.wall_secs = Some(median);
    result.steps_per_sec = Some(steps as f64 / median.max(1e-12));
    result.wall_secs_each = t.wall_secs;
    // Finite but with energy from nowhere past a tenth of the start's: not an answer
    // (`bench accuracy`'s rule for a stable run).
    let gained = e.balance_j() - t.start_balance_j;
    let scale = crate::accuracy::energy_scale(model);
    if crate::accuracy::stayed_stable(gained, scale) {
        result.status = Status::Ok;
    } else {
        result.status = Status::Diverged;
        result.message = Some(format!(
            "diverged by energy: the energy balance grew by {gained:.3e} J, {:.0}% of the initial mechanical energy (more than 10%); a smaller step or a stabler integrator holds it",
            100.0 * gained / scale
        ));
    }
    Ok(TimedEnd::Ended(Some(t.state.x)))
}
