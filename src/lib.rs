//! Hooke: mass-spring systems (hair, cloth, jello) stepped on the CPU reference backend (and,
//! next, wgpu compute), streamed to the Rerun viewer.
//!
//! Data flows one way: [`scene`] → [`model`] → [`backend`] stepped by [`sim`] → [`record`].

pub mod accuracy;
pub mod auto_dt;
pub mod backend;
pub mod bench;
pub mod check;
pub mod cpu;
pub mod error;
pub mod gpu;
pub mod integrator;
pub mod model;
pub mod pacing;
pub mod progress;
pub mod record;
pub mod reference;
pub mod run;
pub mod scene;
pub mod settings;
pub mod sim;
pub mod stability;
pub mod state;
pub mod viewer;

pub use error::{Error, Result};
