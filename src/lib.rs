//! Hooke: mass-spring systems (hair, cloth, jello) stepped on wgpu compute shaders or the CPU
//! reference backend, streamed to the Rerun viewer.
//!
//! Data flows one way: [`scene`] → [`model`] → a [`backend::Backend`] ([`gpu`] or [`cpu`],
//! chosen by [`select`]) stepped by [`sim`] → [`record`]. Every command gets its settings, model
//! and backend through [`prepare`]; [`run`] joins the simulation and recorder threads. Imports
//! run one way, from the data at the bottom to the commands at the top: docs/ARCHITECTURE.md
//! draws the layers, and `tests/layers.rs` keeps them.

pub mod accuracy;
pub mod auto_dt;
pub mod backend;
pub mod bench;
pub mod compare_entry;
pub mod comparison;
pub mod conformance;
pub mod contact_law;
pub mod cpu;
pub mod divergence;
pub mod error;
pub mod gpu;
pub mod integrator;
pub mod mesh;
pub mod model;
pub mod pacing;
pub mod physics;
pub mod prepare;
pub mod progress;
pub mod real;
pub mod record;
pub mod recording_size;
pub mod reference;
pub mod rrd_file;
pub mod run;
pub mod scene;
pub mod select;
pub mod settings;
pub mod sim;
pub mod solver_watch;
pub mod spring_kind;
pub mod stability;
pub mod state;
mod twins;
pub mod viewer;

pub use error::{Error, Result};
