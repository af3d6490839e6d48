//! The model a backend steps: masses, springs, adjacency, bodies and effects, all static.

use crate::laws::spring_kind::SpringKindTag;
use crate::state::State;

use super::colliders::Effects;
use super::springs::{Adjacency, Spring, SpringLimits};

/// A named group of masses and the springs between them.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyInfo {
    pub name: String,
    pub shape: BodyShape,
    pub masses: std::ops::Range<u32>,
    pub springs: std::ops::Range<u32>,
}

impl BodyInfo {
    /// The grid's counts along its axes, for a grid body.
    pub fn grid(&self) -> Option<&[u32]> {
        match &self.shape {
            BodyShape::Grid(g) => Some(g),
            BodyShape::Mesh(_) => None,
        }
    }
}

/// What a body's masses were laid out from.
#[derive(Debug, Clone, PartialEq)]
pub enum BodyShape {
    /// Masses along each grid axis (x fastest).
    Grid(Vec<u32>),
    /// A user's triangle mesh.
    Mesh(std::sync::Arc<MeshShape>),
}

/// A mesh body's surface: the file's triangles over vertices that are masses (cloth, a shell)
/// or that follow a lattice's cells (a filled soft body).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshShape {
    /// The file the mesh came from, as the scene names it.
    pub file: String,
    pub triangles: Vec<[u32; 3]>,
    pub vertices: MeshVertices,
    /// Every edge has two triangles: the surface is seen from outside only.
    pub closed: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub enum MeshVertices {
    /// Vertex `v` is mass `masses[v]` (model-wide).
    Masses(Vec<u32>),
    /// Vertex `v` is embedded in a lattice cell whose corners are masses (model-wide).
    Embedded(Vec<crate::mesh::Embedded>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub bodies: Vec<BodyInfo>,
    pub mass_kg: Vec<f32>,
    /// 0 for pinned masses: they feel forces but never move.
    pub inv_mass: Vec<f32>,
    pub springs: Vec<Spring>,
    pub spring_kind: Vec<SpringKindTag>,
    pub adjacency: Adjacency,
    pub effects: Effects,
    pub initial: State,
    /// Per spring, when some body has plasticity or tearing; empty otherwise.
    pub limits: Vec<SpringLimits>,
    /// Index into `bodies` of each mass (mass–mass contact between bodies only asks it).
    pub mass_body: Vec<u32>,
}

impl Model {
    pub fn mass_count(&self) -> usize {
        self.mass_kg.len()
    }
    pub fn spring_count(&self) -> usize {
        self.springs.len()
    }
    pub fn pinned_count(&self) -> usize {
        self.inv_mass.iter().filter(|&&w| w == 0.0).count()
    }
    pub fn springs_of_kind(&self, kind: SpringKindTag) -> usize {
        self.spring_kind.iter().filter(|&&k| k == kind).count()
    }
    /// The springs' limits with the relaxation of one step of `dt_secs` filled in (f32 from f64,
    /// the same on both backends).
    pub fn spring_limits(&self, dt_secs: f64) -> Vec<SpringLimits> {
        self.limits
            .iter()
            .map(|l| SpringLimits {
                relax: if l.creep_per_s > 0.0 {
                    (-(-f64::from(l.creep_per_s) * dt_secs).exp_m1()) as f32
                } else {
                    0.0
                },
                ..*l
            })
            .collect()
    }
    /// The body that mass `i` belongs to, and its index within that body.
    pub fn body_of_mass(&self, i: u32) -> Option<(&BodyInfo, u32)> {
        self.bodies
            .iter()
            .find(|b| b.masses.contains(&i))
            .map(|b| (b, i - b.masses.start))
    }
}
