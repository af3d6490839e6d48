//! The recorder: turns snapshots into Rerun entities on the `frame` and `sim_time` timelines.
//!
//! Layout (see ARCHITECTURE.md and docs/guide/recording.md):
//! - `world/<body>/surface`: a sheet, or a block's outer faces, as a `Mesh3D` coloured by strain
//!   ([`surface`]); triangle indices logged once, per frame only vertex positions and colours;
//! - `world/<body>/springs`: line segments coloured by strain with hover values ([`springs`]),
//!   for small bodies and strands by default (`--springs`);
//! - `world/<body>/masses`: points for strands, and for sheets and blocks with `--masses`;
//!   `world/<body>/pins` for the pinned masses of sheets and blocks, once;
//! - `world/most_strained`: the most strained spring of the frame, with a leader up to its label
//!   (`world/most_strained/label`), which stands beside the spring, not over it;
//! - `world/colliders/*`, `world/ground`; `energy/*` in joules; `stats/*`, one plot per unit, and
//!   `stats/strain_histogram` ([`histogram`]); `scene`, `legend` text documents.
//!
//! What never changes is logged once with `log_static`; nothing is allocated per spring per frame.
//!
//! Rooms: `recorder.rs` (the `Recorder` and one frame's logging), `statics.rs` (what is logged
//! once: scene, topology, pins, ground and colliders), `scalars.rs` (the plotted values of a
//! frame), `series.rs` (which series there are, in which plot), `palette.rs` (colours),
//! `legend.rs` (the `legend` document), `blueprint.rs` (the default layout), `framing.rs` (where its 3D view's eye starts), `gap_scale.rs` (a comparison's gap colour bar), `options.rs`
//! (`--springs`, `--masses`), `error.rs`.

pub mod blueprint;
mod compare;
mod compare_layout;
mod digest;
mod error;
mod framing;
mod gap_scale;
pub mod histogram;
mod legend;
mod options;
pub mod palette;
mod recorder;
mod rrd_failure;
pub mod rrd_file;
mod scalars;
pub mod shading;
pub mod series;
pub mod springs;
mod statics;
mod strain_summary;
pub mod surface;
pub mod surface_strain;
pub mod viewer;

pub use blueprint::{APPLICATION_ID, Takes, send_blueprint};
pub use compare::{CompareRecorder, EntryName};
pub use compare_layout::{ColourBy, CompareLayout, EntryTally};
pub use digest::{Digester, digesting};
pub use error::{LayoutError, RecordError};
pub use options::{RecordOptions, describe};
pub use palette::{Rgb, strain_color};
pub use recorder::{Recorder, Root};
pub use series::{MORE_SERIES, Plot, SERIES, Series, When};
pub use springs::SpringSelection;
pub use strain_summary::{StrainSummary, labelled_springs, most_strained};
pub use surface::{MAX_SURFACE_SIDE, SurfaceDetail};
