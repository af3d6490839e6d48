//! What implicit Euler's and BDF2's CPU solve keeps between steps: the system linearised at the
//! step's start (and `linearise`, which makes it), the solver's vectors, the preconditioner, and
//! how each step's solve went.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::backward::History;
use super::chunks::{CHUNK, PARALLEL_MIN_MASSES, each_mass};
use super::multigrid::Multigrid;
use super::system_blocks::{ContactBlock, SpringTerms};
use crate::model::{Model, Spring, poses_at};
use crate::physics::Preconditioner;

/// How one implicit step's linear solve went.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveStats {
    /// Newton iterations of the step, a halving of an update that overshot counting as one.
    pub newton: u32,
    /// Conjugate-gradient iterations over all of the step's Newton iterations.
    pub iterations: u32,
    /// Largest final residual of the step's linear solves, each relative to the Newton residual
    /// it started from: at most CG_FORCING when every solve converged, up to 1 when one ran
    /// out of iterations. (VBD: the step's residual |h f − M Δv| relative to |h f|.)
    pub residual: f64,
    /// |h f − M Δv| / |h f| at the iterate the step ended at (Newton: the last evaluated, or
    /// for a step short of its rule the best it solved from), and whether the step met its
    /// rule (Newton: tolerance, floor or a negligible update in its iterations; VBD_RESIDUAL).
    pub step_residual: f64,
    pub met: bool,
}

/// The system linearised at x₀.
#[derive(Debug, Default)]
pub struct Linearisation {
    pub(super) springs: Vec<SpringTerms>,
    pub(super) contacts: Vec<ContactBlock>,
}

impl Linearisation {
    pub(super) fn new(model: &Model) -> Self {
        Linearisation {
            springs: vec![SpringTerms::default(); model.spring_count()],
            contacts: vec![ContactBlock::default(); model.mass_count()],
        }
    }
}

/// Scratch for the solve, allocated once per backend.
#[derive(Debug, Default)]
pub struct ImplicitWork {
    pub(super) lin: Linearisation,
    pub(super) acc: Vec<Vec3>,
    pub(super) b: Vec<Vec3>,
    pub(super) r: Vec<Vec3>,
    pub(super) z: Vec<Vec3>,
    pub(super) p: Vec<Vec3>,
    pub(super) ap: Vec<Vec3>,
    pub(super) dv: Vec<Vec3>,
    /// Each mass's diagonal block of the system, inverted: the preconditioner.
    pub(super) block_inv: Vec<Mat3>,
    /// Δv so far, and the iterate's state.
    pub(super) dv_total: Vec<Vec3>,
    /// Δv at the iterate with the least residual Newton solved from, where a step that ends
    /// short of its rule ends (`implicit_step`).
    pub(super) best_dv: Vec<Vec3>,
    pub(super) xk: Vec<Vec3>,
    pub(super) vk: Vec<Vec3>,
    /// Large systems' preconditioner (block Jacobi without it).
    pub(super) multigrid: Option<Multigrid>,
    /// BDF2's last step start.
    pub(super) history: History,
    /// The model's weight, which Newton's rule judges an iterate against at least
    /// (`physics::weight_norm_n`), taken once.
    pub(super) weight_n: f32,
}

impl ImplicitWork {
    /// Scratch for `model`'s solves, preconditioned by `preconditioner` (block Jacobi where
    /// `model` has no coarse level to make).
    pub fn new(model: &Model, preconditioner: Preconditioner) -> Self {
        let n = model.mass_count();
        let zeros = || vec![Vec3::ZERO; n];
        Self {
            lin: Linearisation::new(model),
            acc: zeros(),
            b: zeros(),
            r: zeros(),
            z: zeros(),
            p: zeros(),
            ap: zeros(),
            dv: zeros(),
            block_inv: vec![Mat3::IDENTITY; n],
            dv_total: zeros(),
            best_dv: zeros(),
            xk: zeros(),
            vk: zeros(),
            multigrid: match preconditioner {
                Preconditioner::Multigrid => Multigrid::new(model),
                Preconditioner::BlockJacobi => None,
            },
            history: History::default(),
            weight_n: crate::physics::weight_norm_n(model),
        }
    }
}

/// The system at `x` (moving at `v`) and time `t`: each spring's terms and each movable mass's
/// pushing contacts.
pub(super) fn linearise(
    model: &Model,
    springs: &[Spring],
    (x, v): (&[Vec3], &[Vec3]),
    t: f64,
    h: f32,
    lin: &mut Linearisation,
) {
    let terms_of = |terms: &mut SpringTerms, s: &Spring| {
        *terms = SpringTerms::at(s, x[s.a as usize], x[s.b as usize], h);
    };
    if lin.springs.len() >= PARALLEL_MIN_MASSES {
        lin.springs
            .par_chunks_mut(CHUNK)
            .zip(springs.par_chunks(CHUNK))
            .for_each(|(t, s)| t.iter_mut().zip(s).for_each(|(t, s)| terms_of(t, s)));
    } else {
        lin.springs
            .iter_mut()
            .zip(springs)
            .for_each(|(t, s)| terms_of(t, s));
    }
    let poses = poses_at(&model.effects.colliders, t);
    each_mass(&mut lin.contacts, |i, contacts| {
        *contacts = if model.inv_mass[i] == 0.0 {
            ContactBlock::default()
        } else {
            ContactBlock::at(&model.effects, &poses, (x[i], v[i]), model.mass_kg[i], h)
        };
    });
}

/// The system linearised at `x` (for the tests of its preconditioners).
#[cfg(test)]
pub(super) fn linearised_at(model: &Model, x: &[Vec3], h: f32) -> Linearisation {
    let mut lin = Linearisation::new(model);
    let at_rest = vec![Vec3::ZERO; x.len()];
    linearise(model, &model.springs, (x, &at_rest), 0.0, h, &mut lin);
    lin
}
