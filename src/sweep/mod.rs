//! `hooke sweep`: many runs of one scene, its values varied over a grid or a list ([`file`]),
//! each point planned in full ([`plan`]) and run by `hooke sweep point` ([`point`]) on this
//! machine ([`local`]) or as a Slurm job array ([`slurm`]); each point's `result.json` is written
//! last and atomically, so a sweep's state is its files ([`status`]), and [`report`] reads them.
//!
//! ```text
//! DIR/plan.json             every point's scene, backend and reference, in full
//! DIR/points/NNNN.rrd       point NNNN's recording (a folder `rerun server -d` serves)
//! DIR/points/NNNN/          its scene.toml, log.txt and result.json
//! DIR/references/KEY.json   a reference's end, shared by the points of its scene
//! DIR/slurm/                the job script, the jobs submitted and each task's output
//! ```

mod apply;
pub mod cost;
pub mod file;
pub mod local;
pub mod plan;
pub mod point;
mod properties;
mod reference;
pub mod report;
pub mod result;
pub mod slurm;
pub mod status;

use std::path::Path;

use crate::error::{Error, Result};

pub use plan::{Layout, Plan};

/// Read the sweep file at `file` and plan it.
pub fn plan_file(file: &Path) -> Result<Plan> {
    let spec = self::file::read(file).map_err(|e| Error::Sweep(e.to_string()))?;
    plan::make(&spec).map_err(|e| Error::Sweep(e.to_string()))
}

/// Make the sweep's folder `dir` with its plan. A folder that holds another sweep is refused:
/// `resume` finishes that one.
pub fn start(plan: &Plan, dir: &Path) -> Result<()> {
    let layout = Layout::new(dir);
    if layout.plan().exists() {
        return Err(Error::Sweep(format!(
            "{} already holds a sweep: `hooke sweep resume {}` finishes it, `hooke sweep status {}` says where it stands; or give another --out",
            dir.display(),
            dir.display(),
            dir.display()
        )));
    }
    let io = |e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", dir.display()));
    std::fs::create_dir_all(layout.points()).map_err(io)?;
    plan::write_json_atomic(&layout.plan(), plan).map_err(io)
}
