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
pub mod reference;
pub mod report;
pub mod result;
pub mod slurm;
pub mod status;
pub mod tally;

pub use plan::{Layout, Plan};
