//! The binary's own code, above the library: the command line (`args`), where a run records
//! (`sink`), and the commands (`run`, `check`, `scenes`, `bench`). `main.rs` parses and
//! dispatches.

mod args;
mod bench;
mod check;
mod check_effects;
mod outcome;
mod run;
mod scenes;
mod sink;
mod sweep;

pub use args::{Cli, Command};
pub use bench::bench;
pub use check::check;
pub use outcome::Outcome;
pub use run::{RunArgs, run};
pub use scenes::scenes;
pub use sweep::sweep;
