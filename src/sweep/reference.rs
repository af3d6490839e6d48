//! The reference a sweep's errors are measured against: the point's scene under the reference's
//! solver, run once per scene and backend and kept in `references/KEY.json` (written
//! atomically, so points that reach it together at worst both compute it).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::backend::StopFlags;
use crate::error::{Error, Result};
use crate::run::prepare;

use super::plan::{self, Layout, Plan, PlannedReference};

#[derive(Serialize, Deserialize)]
struct ReferenceEnd {
    integrator: String,
    dt_secs: f64,
    digest: String,
    positions: Vec<[f32; 3]>,
}

/// The reference's end positions; `None` when `cancel` stopped it.
pub fn end(
    plan: &Plan,
    layout: &Layout,
    r: &PlannedReference,
    cancel: &Arc<AtomicBool>,
) -> Result<Option<Vec<Vec3>>> {
    let path = layout.reference(&r.key);
    let cached = std::fs::read_to_string(&path)
        .ok()
        .and_then(|t| serde_json::from_str::<ReferenceEnd>(&t).ok());
    if let Some(c) = cached {
        return Ok(Some(c.positions.into_iter().map(Vec3::from).collect()));
    }
    let failed = |why: String| {
        Error::Sweep(format!(
            "the sweep's reference cannot be run ({why}): give [reference] a step it is stable and supported at"
        ))
    };
    let request = super::plan::request(plan, &r.scene_toml, &r.backend)?;
    let planned = prepare::plan(&request, &mut |_| {}).map_err(|e| failed(e.to_string()))?;
    let s = &planned.settings;
    let steps = s.frames * u64::from(s.substeps);
    let stop = StopFlags::new([cancel.clone()]);
    let run =
        crate::accuracy::timed_runs(&planned.model, &request.device, s.step(), steps, 1, &stop);
    if cancel.load(Ordering::SeqCst) {
        return Ok(None);
    }
    let state = run.map_err(|e| failed(e.to_string()))?.state;
    let end = ReferenceEnd {
        integrator: s.integrator.name().to_owned(),
        dt_secs: s.dt_secs,
        digest: format!("{:016x}", state.digest()),
        positions: state.x.iter().map(|p| p.to_array()).collect(),
    };
    let io = |e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", path.display()));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(io)?;
    }
    plan::write_json_atomic(&path, &end).map_err(io)?;
    Ok(Some(state.x))
}

/// The RMS over the masses of the distance between two ends.
pub fn rms_gap(reference: &[Vec3], x: &[Vec3]) -> Result<f64> {
    if reference.len() != x.len() || x.is_empty() {
        return Err(Error::Sweep(format!(
            "the reference has {} masses and the point {}: a reference runs the point's own scene",
            reference.len(),
            x.len()
        )));
    }
    let sum: f64 = reference
        .iter()
        .zip(x)
        .map(|(a, b)| f64::from((*a - *b).length_squared()))
        .sum();
    Ok((sum / x.len() as f64).sqrt())
}
