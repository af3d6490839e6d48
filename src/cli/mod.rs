//! The binary's own code, above the library: the command line (`args`), where a run records
//! (`sink`), and the commands that print (`run`, `bench`). `main.rs` parses and dispatches.

mod args;
mod bench;
mod run;
mod sink;

pub use args::{Cli, Command, DeviceArgs};
pub use bench::bench;
pub use run::{Outcome, RunArgs, run};
