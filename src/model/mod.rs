//! The static model a backend steps: masses, springs, the per-mass CSR adjacency the force gather
//! walks, pins and effects. Built from a validated [`crate::scene::Scene`] by [`build`] or, for
//! tests and examples, by hand with [`ModelBuilder`].
//!
//! This file only names the parts; each lives in the file named for what it holds.

mod builder;
mod colliders;
mod from_mesh;
mod from_scene;
pub mod memory_need;
mod placement;
mod springs;
mod system;

pub use builder::ModelBuilder;
pub use colliders::{
    Collider, ContactModel, Effects, GroundCollider, MassContact, Path, Pose, Shape, poses_at,
};
pub use from_scene::build;
pub use placement::{Buried, buried};
pub use springs::{Adjacency, NO_LIMITS, Neighbor, Spring, SpringLimits};
pub use system::{BodyInfo, BodyShape, MeshShape, MeshVertices, Model};

// The contact law and the spring kinds sit below the scene (whose validation reads them); the
// model is where most code looks for them.
pub use crate::laws::contact_law::{
    MIN_RESTITUTION, damping_ratio_for_restitution, restitution_of_damping_ratio,
};
pub use crate::laws::spring_kind::{SpringKindTag, kind_offsets};
