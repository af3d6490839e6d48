//! `hooke bench`: how fast a backend steps (`throughput`, `--effects`), what the recorder costs
//! (`record`), whether a long run holds its memory (`soak`), and what accuracy costs
//! (`accuracy`: a sweep of [`crate::accuracy`]'s ladder).

pub mod accuracy;
mod effects;
mod record;
mod soak;
mod throughput;

pub use effects::{EffectCosts, effect_costs, format_effect_costs};
pub use record::{
    RecordBench, RecordBenchOptions, RecordPass, format_record, peak_resident_bytes, record,
};
pub use soak::{Soak, format_soak, resident_bytes, soak};
pub use throughput::{
    Throughput, ThroughputOptions, format_throughput, throughput, throughput_json,
};
