//! Scenes: what a user writes (TOML, or a built-in name) before it becomes a
//! [`crate::model::Model`].
//!
//! The structs of [`format`] are the file format itself. A scene is only handed out by [`load`] /
//! [`from_toml`] after validation has checked every value, so the model builder can trust it.

mod builtin;
pub mod compare_entry;
mod error;
mod format;
mod format_body;
mod load;
mod locate;
mod mesh_checks;
mod mesh_file;
mod rules;
pub mod settings;
mod validate;
mod validate_body;

pub use builtin::{BUILT_IN, BUILT_IN_MESHES, BuiltIn};
pub use error::{LoadError, SceneError, SceneOrigin};
pub use format::*;
pub use format_body::*;
pub use load::{LoadedScene, from_toml, load};
pub use locate::line_col;
pub use rules::{MAX_START_SPEED_M_PER_S, MOST_SWEEPS};
pub use validate::MAX_COLLIDERS;
