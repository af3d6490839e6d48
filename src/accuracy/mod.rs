//! `hooke bench accuracy`'s parts: what accuracy costs in time. Every integrator over a ladder
//! of time steps ([`ladder`]) against an f64 RK4 reference ([`reference`]), each run timed
//! ([`timing`]): position error, energy drift, stability and wall time per simulated second;
//! each integrator's largest stable dt found by search beside the estimate that `hooke check`
//! gives. Written as Markdown, CSV and an SVG work-precision chart ([`chart`]). The runs
//! themselves are a sweep's points (`crate::bench::accuracy`), on this machine or a cluster.

pub mod chart;
mod ladder;
mod limits;
pub mod reference;
mod report;
mod results;
mod stable_dt;
mod timing;

pub use ladder::{LadderOptions, ladder_to_estimate, step_ladder};
pub use limits::{LimitRow, Measured, limits_markdown, measure_limits};
pub use report::{
    TIE_SHARE, cheapest_per_level, cheapest_rows, check_out_dir, markdown, record, write_outputs,
};
pub use results::{Accuracy, Found, Outcome, Row, StableDt};
pub use stable_dt::{
    IMPLICIT_SEARCH_UP_TO_SECS, dissipated_pct, energy_scale, is_stable, is_stable_on,
    search_range, search_stable_dt, search_stable_dt_on, stayed_stable,
};
pub use timing::{Repeats, Timed, timed_runs};
