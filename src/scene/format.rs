//! The scene file format itself: `deny_unknown_fields`, SI units in the field names. A value of
//! these types is only handed out after validation (see [`super::load`]).

use serde::{Deserialize, Serialize};

use super::format_body::Body;
use crate::integrator::{AskedEffects, Integrator};

/// A whole scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name, used for the Rerun application id and default `.rrd` name.
    pub name: String,
    /// One line shown by `hooke scenes`.
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub solver: Solver,
    #[serde(default)]
    pub effects: Effects,
    pub bodies: Vec<Body>,
    #[serde(default)]
    pub view: View,
    /// Run as a side-by-side comparison of these entries (`hooke run --compare` overrides).
    #[serde(default)]
    pub compare: Option<Compare>,
}

/// A comparison a scene asks for: the same scene under each entry, in one recording, the first
/// the reference (`hooke run --compare`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compare {
    /// `integrator[@step]` each: `rk4`, `implicit@1/60`, `semi-implicit@dt=1e-4`.
    pub entries: Vec<String>,
    /// Copies on top of each other (the non-reference ones translucent) instead of side by side.
    #[serde(default)]
    pub overlay: bool,
    /// The gap to the reference at which a copy is coloured fully red; a twentieth of the
    /// scene's size when absent.
    #[serde(default)]
    pub gap_range_m: Option<f32>,
}

/// Time stepping. One frame is `substeps` steps of `dt`, and `frame_rate_hz · substeps · dt = 1`;
/// give `substeps` or `dt_secs` (not both), the other follows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Solver {
    #[serde(default)]
    pub integrator: Integrator,
    #[serde(default = "default_frame_rate")]
    pub frame_rate_hz: f64,
    #[serde(default)]
    pub substeps: Option<u32>,
    #[serde(default)]
    pub dt_secs: Option<f64>,
    /// Simulated time to run; `frames` wins when both are given on the command line.
    #[serde(default)]
    pub duration_secs: Option<f64>,
    #[serde(default)]
    pub frames: Option<u64>,
    /// XPBD's constraint iterations per substep (`integrator = "xpbd"`); 1 when absent.
    #[serde(default)]
    pub xpbd_iterations: Option<u32>,
    /// VBD's sweeps over the masses per step (`integrator = "vbd"`); 10 when absent.
    #[serde(default)]
    pub vbd_iterations: Option<u32>,
    /// What preconditions implicit Euler's and BDF2's CG (`"block-jacobi"` or `"multigrid"`);
    /// by the system's size when absent (multigrid from 4 096 masses).
    #[serde(default)]
    pub preconditioner: Option<crate::integrator::Preconditioner>,
}

fn default_frame_rate() -> f64 {
    60.0
}

impl Default for Solver {
    fn default() -> Self {
        Self {
            integrator: Integrator::default(),
            frame_rate_hz: default_frame_rate(),
            substeps: None,
            dt_secs: None,
            duration_secs: None,
            frames: None,
            xpbd_iterations: None,
            vbd_iterations: None,
            preconditioner: None,
        }
    }
}

/// Effects a scene opts into. Anything absent is not simulated at all.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Gravitational acceleration, e.g. `[0, -9.81, 0]` (y is up).
    #[serde(default)]
    pub gravity_m_per_s2: Option<[f32; 3]>,
    /// Linear air drag as a rate: each mass feels `-m · air_drag_per_s · v`.
    #[serde(default)]
    pub air_drag_per_s: Option<f32>,
    #[serde(default)]
    pub ground: Option<Ground>,
    #[serde(default)]
    pub spheres: Vec<Sphere>,
    #[serde(default)]
    pub boxes: Vec<BoxCollider>,
    #[serde(default)]
    pub planes: Vec<Plane>,
    /// Contact between mass points, of one body with itself and between bodies.
    #[serde(default)]
    pub self_collision: Option<SelfCollision>,
}

impl AskedEffects for Effects {
    fn mass_contact(&self) -> bool {
        self.self_collision.is_some()
    }
}

/// How a collider pushes back: a penalty spring along the contact normal, damped so that an
/// impact keeps the given coefficient of restitution, plus Coulomb friction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Penalty stiffness per mass point in contact.
    pub stiffness_n_per_m: f32,
    /// Coulomb friction coefficient (0 = frictionless).
    pub friction: f32,
    /// Coefficient of restitution of a single mass hitting the collider (0 = no bounce, 1 = elastic).
    pub restitution: f32,
}

fn default_contact_stiffness() -> f32 {
    1.0e4
}
fn default_restitution() -> f32 {
    0.5
}

/// Declares a collider's table: its own fields, then the contact fields every collider shares
/// (so that each collider spells them, their defaults and their order the same way), and
/// `contact()`, the one form the model reads them in. `moving` adds the fields of a scripted
/// path: `center_m` first, `velocity_m_per_s` and `keyframes` after the collider's own.
macro_rules! collider {
    (moving $(#[$doc:meta])* $name:ident { $($fields:tt)* }) => {
        collider! {
            $(#[$doc])*
            $name {
                #[serde(default)]
                pub center_m: Option<[f32; 3]>,
                $($fields)*
                #[serde(default)]
                pub velocity_m_per_s: [f32; 3],
                /// Positions at given times, passed through in straight lines; held before the
                /// first and after the last.
                #[serde(default)]
                pub keyframes: Vec<Keyframe>,
            }
        }
    };
    ($(#[$doc:meta])* $name:ident { $($fields:tt)* }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $($fields)*
            /// Penalty stiffness per mass point in contact.
            #[serde(default = "default_contact_stiffness")]
            pub stiffness_n_per_m: f32,
            /// Coulomb friction coefficient (0 = frictionless).
            #[serde(default)]
            pub friction: f32,
            /// Coefficient of restitution of a single mass hitting the collider (0 = no bounce,
            /// 1 = elastic).
            #[serde(default = "default_restitution")]
            pub restitution: f32,
        }

        impl $name {
            pub fn contact(&self) -> Contact {
                Contact {
                    stiffness_n_per_m: self.stiffness_n_per_m,
                    friction: self.friction,
                    restitution: self.restitution,
                }
            }
        }
    };
}

collider! {
    /// The plane `y = height_m`, solid below.
    Ground {
        #[serde(default)]
        pub height_m: f32,
    }
}

collider! {
    moving
    /// A solid sphere. It moves on a path: from `center_m` at t = 0 at constant
    /// `velocity_m_per_s` (zero: fixed), or through `keyframes` (then leave out `center_m`).
    Sphere {
        pub radius_m: f32,
    }
}

/// One key of a collider's path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    pub time_secs: f64,
    pub center_m: [f32; 3],
}

collider! {
    moving
    /// A solid axis-aligned box, on a path like a sphere's.
    BoxCollider {
        /// Half its size along x, y and z.
        pub half_extents_m: [f32; 3],
    }
}

collider! {
    /// A fixed plane through `point_m`, solid on the side away from `normal` (a wall, a slope).
    Plane {
        pub point_m: [f32; 3],
        /// Points out of the solid side; need not be unit length.
        pub normal: [f32; 3],
    }
}

/// Mass–mass contact: every mass is a sphere of `radius_m`, and two that overlap are pushed apart
/// by a penalty spring along the line between them, damped so that a pair's impact keeps the
/// given coefficient of restitution, plus Coulomb friction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfCollision {
    /// Radius of each mass's contact sphere: a pair touches closer than `2 · radius_m`.
    pub radius_m: f32,
    /// Penalty stiffness per contacting pair.
    pub stiffness_n_per_m: f32,
    /// Coefficient of restitution of a pair impact (0 = no bounce, 1 = elastic).
    #[serde(default = "default_restitution")]
    pub restitution: f32,
    /// Coulomb friction coefficient between masses (0 = frictionless).
    #[serde(default)]
    pub friction: f32,
    /// Masses of one body collide with each other too; `false`: only masses of different bodies.
    #[serde(default = "default_within_bodies")]
    pub within_bodies: bool,
}

fn default_within_bodies() -> bool {
    true
}

impl SelfCollision {
    pub fn contact(&self) -> Contact {
        Contact {
            stiffness_n_per_m: self.stiffness_n_per_m,
            friction: self.friction,
            restitution: self.restitution,
        }
    }
}

/// How the recording presents the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct View {
    /// Strain mapped to the ends of the colour scale: `-strain_range` is fully blue (compressed),
    /// `+strain_range` fully red (stretched).
    #[serde(default = "default_strain_range")]
    pub strain_range: f32,
}

fn default_strain_range() -> f32 {
    0.1
}

impl Default for View {
    fn default() -> Self {
        Self {
            strain_range: default_strain_range(),
        }
    }
}
