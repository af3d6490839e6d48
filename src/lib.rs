//! Hooke: mass-spring systems (hair, cloth, jello) stepped on wgpu compute shaders or the CPU
//! reference backend, streamed to the Rerun viewer.
//!
//! Data flows one way: [`scene`] → [`model`] → a [`backend::Backend`] ([`gpu`] or [`cpu`],
//! chosen by [`run::select`]) stepped by [`run::sim`] → [`record`]. Every command gets its
//! settings, model and backend through [`run::prepare`]; [`run::run`] joins the simulation and
//! recorder threads. Imports run one way, from the data at the bottom to the commands at the
//! top: docs/ARCHITECTURE.md draws the layers, and `tests/layers.rs` keeps them.

// In layer order, bottom first: each module imports only those listed before it.
pub mod real;
pub mod state;
pub mod laws;
pub mod integrator;
pub mod mesh;
pub mod scene;
pub mod model;
pub mod stability;
pub mod physics;
pub mod backend;
pub mod cpu;
pub mod gpu;
pub mod conformance;
pub mod record;
pub mod error;
pub mod run;
pub mod accuracy;
pub mod sweep;
pub mod bench;

pub use error::{Error, Result};
