//! The reference a sweep's errors are measured against, computed once per scene and solver and
//! kept in `references/KEY.json` (written atomically, so points that reach it together at worst
//! both compute it): the point's scene under the sweep file's `[reference]` solver, or f64 RK4
//! (`bench accuracy`'s, computed before its points start).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

use crate::backend::StopFlags;
use crate::error::{Error, Result};
use crate::run::prepare;

use super::plan::{self, Layout, Plan, PlannedReference, ReferenceSolver};

#[derive(Serialize, Deserialize)]
struct ReferenceEnd {
    solver: ReferenceSolver,
    /// The end state's digest, where a backend computed it.
    digest: Option<String>,
    /// f64 for RK4's end; an f32 backend's end, exactly, for the others.
    positions: Vec<[f64; 3]>,
}

/// The reference's end positions; `None` when `cancel` stopped it.
pub fn end(
    plan: &Plan,
    layout: &Layout,
    r: &PlannedReference,
    cancel: &Arc<AtomicBool>,
) -> Result<Option<Vec<DVec3>>> {
    let path = layout.reference(&r.key);
    let cached = std::fs::read_to_string(&path)
        .ok()
        .and_then(|t| serde_json::from_str::<ReferenceEnd>(&t).ok());
    if let Some(c) = cached {
        return Ok(Some(c.positions.into_iter().map(DVec3::from).collect()));
    }
    let failed = |why: String| {
        Error::Sweep(format!(
            "the sweep's reference cannot be run ({why}): give [reference] a step it is stable and supported at"
        ))
    };
    let backend = match &r.solver {
        ReferenceSolver::Run { backend } => backend.as_str(),
        ReferenceSolver::F64Rk4 { .. } => "cpu",
    };
    let request = super::plan::request(plan, &r.scene_toml, backend)?;
    let planned = prepare::plan(&request, &mut |_| {}).map_err(|e| failed(e.to_string()))?;
    let s = &planned.settings;
    let (positions, digest) = match r.solver {
        ReferenceSolver::Run { .. } => {
            let steps = s.frames * u64::from(s.substeps);
            let stop = StopFlags::new([cancel.clone()]);
            let run = crate::accuracy::timed_runs(
                &planned.model,
                &request.device,
                s.step(),
                steps,
                crate::accuracy::Repeats::exactly(1),
                &stop,
            );
            if cancel.load(Ordering::SeqCst) {
                return Ok(None);
            }
            let state = run.map_err(|e| failed(e.to_string()))?.state;
            let x = state.x.iter().map(|p| p.as_dvec3()).collect();
            (x, Some(format!("{:016x}", state.digest())))
        }
        ReferenceSolver::F64Rk4 { dt_secs } => {
            let mut rk4 = crate::accuracy::reference::Reference::new(planned.model.clone());
            if !rk4.advance_to_unless(s.duration_secs(), dt_secs, cancel) {
                return Ok(None);
            }
            (rk4.x, None)
        }
    };
    let end = ReferenceEnd {
        solver: r.solver.clone(),
        digest,
        positions: positions.iter().map(|p| p.to_array()).collect(),
    };
    let io = |e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", path.display()));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(io)?;
    }
    plan::write_json_atomic(&path, &end).map_err(io)?;
    Ok(Some(positions))
}

/// The distances of an end from its reference, over the masses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    pub rms_m: f64,
    pub max_m: f64,
}

/// How far `x` ended from the reference's end, in f64.
pub fn gap(reference: &[DVec3], x: &[Vec3]) -> Result<Gap> {
    if reference.len() != x.len() || x.is_empty() {
        return Err(Error::Sweep(format!(
            "the reference has {} masses and the point {}: a reference runs the point's own scene",
            reference.len(),
            x.len()
        )));
    }
    let (sum, max) = reference
        .iter()
        .zip(x)
        .map(|(a, b)| (b.as_dvec3() - *a).length())
        .fold((0.0, 0.0f64), |(sum, max), d| (sum + d * d, max.max(d)));
    Ok(Gap {
        rms_m: (sum / x.len() as f64).sqrt(),
        max_m: max,
    })
}

/// Every reference the points in `indices` need and the cache lacks, computed now (before the
/// points, which would otherwise each compute it at once): `false` when `cancel` stopped it.
pub fn prepare_all(
    plan: &Plan,
    layout: &Layout,
    indices: &[usize],
    cancel: &Arc<AtomicBool>,
) -> Result<bool> {
    let mut seen = std::collections::BTreeSet::new();
    for r in indices
        .iter()
        .filter_map(|&i| plan.points.get(i)?.reference.as_ref())
    {
        if seen.insert(r.key.clone()) && end(plan, layout, r, cancel)?.is_none() {
            return Ok(false);
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cached reference reads back exactly what was computed: points that compute it and
    /// points that read it measure the same error, to the bit (a Slurm sweep's errors equal a
    /// local one's). serde_json's default float parsing missed some f32 ends by an ulp.
    #[test]
    fn a_cached_reference_reads_back_to_the_bit() {
        let mut state = 0x9e37_79b9u32;
        let positions: Vec<[f64; 3]> = (0..20_000)
            .map(|_| {
                let mut next = || {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    f64::from(f32::from_bits(0x3c00_0000 + (state % 0x0300_0000)))
                };
                [next(), -next(), next()]
            })
            .collect();
        let end = ReferenceEnd {
            solver: ReferenceSolver::F64Rk4 { dt_secs: 1e-3 },
            digest: None,
            positions: positions.clone(),
        };
        let text = serde_json::to_string(&end).unwrap_or_default();
        let back: ReferenceEnd = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}"));
        let off = positions
            .iter()
            .zip(&back.positions)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            off,
            0,
            "{off} of {} positions came back changed",
            positions.len()
        );
    }
}
