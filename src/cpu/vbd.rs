//! Vertex Block Descent (Chen, Liu, Yang & Yuksel, "Vertex Block Descent", SIGGRAPH 2024): the
//! same backward Euler step as `implicit_step`, solved by Gauss–Seidel over the masses instead of
//! Newton and conjugate gradients.
//!
//! Backward Euler asks for the velocity v at the end of the step with
//!   m (v − v₀) = h f(x₀ + h v, v)   for every mass,
//! which is the minimum of the variational energy the paper descends. VBD sweeps the masses
//! colour by colour (`physics::vbd_colouring`: no two masses of a colour share a spring) and moves
//! each one alone to where its own equation holds, to first order, with its neighbours held:
//!   Δvᵢ = Aᵢᵢ⁻¹ (h fᵢ − mᵢ (vᵢ − v₀ᵢ)),   xᵢ = x₀ᵢ + h vᵢ,
//! Aᵢᵢ being mass i's 3 × 3 diagonal block of implicit Euler's system (M − h D − h² K), the
//! paper's per-vertex Hessian times h². The dashpots enter f at the iterate's velocity and their
//! h c n nᵀ enters Aᵢᵢ: the paper's damping (a Rayleigh term on the element's Hessian) with our
//! springs' own c. Contacts, friction and drag enter as they do in implicit Euler. A step runs a
//! fixed number of sweeps (`--vbd-iterations`, 10 by default, as NVIDIA Newton's cloth examples);
//! it starts from the paper's adaptive guess (`vbd_predict`).
//!
//! Not converged after its sweeps, VBD leaves some of the equations unmet: the step's residual
//! |h f − M Δv| relative to |h f| is reported as the solver's residual, and the energy ledger
//! shows what the unmet part does to the energy.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::chunks::PARALLEL_MIN_MASSES;
use super::forces::{Gather, compute_forces, force_on_mass};
use super::implicit_work::SolveStats;
use super::system_blocks::{ContactBlock, SpringTerms, block_times, invert_block, own_block};
use crate::backend::StopFlags;
use crate::model::{Model, Pose, poses_at};
use crate::physics::{MassColouring, VBD_RESIDUAL, vbd_colouring};
use crate::state::State;

/// What a VBD run keeps between steps.
#[derive(Debug, Clone)]
pub struct VbdWork {
    pub colouring: MassColouring,
    pub iterations: u32,
    /// The state at the start of the step.
    x0: Vec<Vec3>,
    v0: Vec<Vec3>,
    /// The velocity at the start of the last step, which the guess's acceleration is taken
    /// from (zero before the first step, as on the GPU).
    v_last: Vec<Vec3>,
    /// A colour's new velocities, computed in parallel before they are written.
    moved: Vec<Vec3>,
    acc: Vec<Vec3>,
}

impl VbdWork {
    pub fn new(model: &Model, iterations: u32) -> Self {
        let n = model.mass_count();
        Self {
            colouring: vbd_colouring(model),
            iterations,
            x0: vec![Vec3::ZERO; n],
            v0: vec![Vec3::ZERO; n],
            v_last: vec![Vec3::ZERO; n],
            moved: Vec::new(),
            acc: vec![Vec3::ZERO; n],
        }
    }
}

/// The first guess (the paper's adaptive initialisation): the velocity v₀ + h ã, ã the part of
/// gravity the masses fell with over the last step (the last step's acceleration along gravity,
/// clamped to [0, |g|]). A mass at rest on the ground is then not pushed into it, and a falling
/// one is not held back. (A pinned mass's velocity is zero, so its guess is where it is.)
pub fn vbd_predict(
    gravity: Option<Vec3>,
    v_last: &[Vec3],
    h: f32,
    (x0, v0): (&[Vec3], &[Vec3]),
    (x, v): (&mut [Vec3], &mut [Vec3]),
) {
    let g = gravity.unwrap_or(Vec3::ZERO);
    let g_len = g.length();
    let down = if g_len > 0.0 { g / g_len } else { Vec3::ZERO };
    for i in 0..x.len() {
        let fell = ((v0[i] - v_last[i]).dot(down) / h).clamp(0.0, g_len);
        v[i] = v0[i] + h * fell * down;
        x[i] = x0[i] + h * v[i];
    }
}

/// The step's end: the start's velocity kept for the next guess.
pub fn vbd_final(v0: &[Vec3], v_last: &mut [Vec3]) {
    v_last.copy_from_slice(v0);
}

/// The step's residual: backward Euler's |h f − M Δv| relative to |h f| over the movable masses,
/// `acc` being the accelerations at the end of the step (0 where nothing moves). VBD's sweeps
/// stop at their count, not at a rule, so this says how far from solved they left the step. The
/// GPU's `vbd_residual` (integrate.wgsl) adds the same terms in f32 by workgroups of 64 masses,
/// where this adds them in f64 in mass order: the two agree to rounding, not to the bit.
pub fn vbd_residual(model: &Model, (v0, v): (&[Vec3], &[Vec3]), acc: &[Vec3], h: f32) -> f64 {
    let (mut unmet, mut momentum) = (0.0f64, 0.0f64);
    for i in 0..v.len() {
        if model.inv_mass[i] != 0.0 {
            let m = model.mass_kg[i];
            let hf = h * m * acc[i];
            unmet += f64::from((hf - m * (v[i] - v0[i])).length_squared());
            momentum += f64::from(hf.length_squared());
        }
    }
    if momentum > 0.0 {
        (unmet / momentum).sqrt()
    } else {
        0.0
    }
}

/// Mass `i`'s velocity after one block solve at the current iterate (x, v): v + Aᵢᵢ⁻¹ bᵢ with
/// bᵢ = h fᵢ − mᵢ (vᵢ − v₀ᵢ). A pinned mass keeps its velocity.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn vbd_solve_mass(
    model: &Model,
    gather: &Gather,
    poses: &[Pose],
    (x, v): (&[Vec3], &[Vec3]),
    v0: Vec3,
    h: f32,
    i: usize,
) -> Vec3 {
    if model.inv_mass[i] == 0.0 {
        return v[i];
    }
    let m = model.mass_kg[i];
    let (a, _) = force_on_mass::<true>(model, gather, poses, x, v, i, h);
    let b = h * m * a - m * (v[i] - v0);
    let e = &model.effects;
    // Added as vbd_finish adds them: its own block, its contacts', then its springs' summed apart
    // (the share of one lane, vbd_mass.wgsl), so that the two agree bit for bit on lavapipe.
    let mut springs = Mat3::ZERO;
    for (j, s) in gather.springs_of(i) {
        if !s.is_broken() {
            springs = SpringTerms::at(s, x[i], x[j], h).add_block(springs);
        }
    }
    let mut block = own_block(m, h, e.air_drag_per_s.unwrap_or(0.0));
    if e.has_contact() {
        block += ContactBlock::at(e, poses, (x[i], v[i]), m, h).block();
    }
    v[i] + block_times(invert_block(block + springs), b)
}

/// One VBD step of `dt`: the guess, `iterations` sweeps over the colours (fewer once `stop` is
/// asked), and the ledger's rates at the end of the step (backward quadrature, as implicit Euler
/// books them).
pub fn vbd_step(
    model: &Model,
    gather: &mut Gather,
    state: &mut State,
    w: &mut VbdWork,
    dt: f32,
    stop: &StopFlags,
) -> SolveStats {
    let h = dt;
    let t_end = state.time_secs + f64::from(h);
    let poses = poses_at(&model.effects.colliders, t_end);
    w.x0.copy_from_slice(&state.x);
    w.v0.copy_from_slice(&state.v);
    vbd_predict(
        model.effects.gravity_m_per_s2,
        &w.v_last,
        h,
        (&w.x0, &w.v0),
        (&mut state.x, &mut state.v),
    );
    let mut sweeps = 0;
    for _ in 0..w.iterations {
        if stop.asked() {
            break;
        }
        sweeps += 1;
        for c in 0..w.colouring.colours() {
            let masses = w.colouring.masses_of(c);
            let solve = |&i: &u32| {
                let i = i as usize;
                vbd_solve_mass(model, gather, &poses, (&state.x, &state.v), w.v0[i], h, i)
            };
            // Masses of one colour share no spring: each reads only its neighbours, which hold
            // still until the whole colour is written.
            w.moved.clear();
            if masses.len() >= PARALLEL_MIN_MASSES {
                masses.par_iter().map(solve).collect_into_vec(&mut w.moved);
            } else {
                w.moved.extend(masses.iter().map(solve));
            }
            for (&i, &vi) in masses.iter().zip(&w.moved) {
                let i = i as usize;
                state.v[i] = vi;
                state.x[i] = w.x0[i] + h * vi;
            }
        }
    }
    let power = compute_forces(model, gather, &state.x, &state.v, t_end, dt, &mut w.acc);
    let residual = vbd_residual(model, (&w.v0, &state.v), &w.acc, h);
    vbd_final(&w.v0, &mut w.v_last);
    state.ledger.accumulate(&power, f64::from(h));
    state.time_secs = t_end;
    state.steps += 1;
    SolveStats {
        newton: 0,
        iterations: sweeps,
        residual,
        step_residual: residual,
        met: residual <= VBD_RESIDUAL,
    }
}
