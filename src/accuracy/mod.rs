//! `hooke bench accuracy`: what accuracy costs in time. Every integrator over a ladder of time
//! steps against an f64 RK4 reference: position error, energy drift, stability and wall time per
//! simulated second; each integrator's largest stable dt found by search beside the estimate that
//! `hooke check` gives. Written as Markdown, CSV and an SVG work-precision chart.

mod chart;
mod limits;
mod measure;
pub mod reference;
mod report;
mod results;
mod stable_dt;

pub use chart::svg;
pub use limits::{LimitRow, Measured, limits_markdown, measure_limits};
pub use measure::{AccuracyOptions, Timed, accuracy, timed_runs};
pub use report::{cheapest_per_level, markdown};
pub use results::{Accuracy, Found, Row, StableDt};
pub use stable_dt::{
    IMPLICIT_SEARCH_UP_TO_SECS, is_stable, is_stable_on, search_range, search_stable_dt,
    search_stable_dt_on,
};
