//! `implicit_step`: backward Euler by Newton's method (Baraff & Witkin 1998), and BDF2 as backward
//! Euler from a blended start (`physics::BackwardStep`, `backward.rs`), each linear system
//! solved matrix-free by conjugate gradients with a 3 × 3 block-Jacobi preconditioner (aggregation
//! multigrid from `physics::MULTIGRID_MIN_MASSES` masses on: `multigrid.rs`) to a tenth of Newton's
//! residual (inexact Newton).
//!
//! Backward Euler asks for Δv with M Δv = h f(x₀ + h (v₀ + Δv), v₀ + Δv). Newton's method on
//! that, from Δv = 0, solves at each iterate (x, v) = (x₀ + h (v₀ + Δv), v₀ + Δv)
//!   (M − h D − h² K) δ = h f(x, v) − M Δv,   Δv ← Δv + δ,
//! with K = ∂f/∂x and D = ∂f/∂v at the iterate, until the residual is within the step's
//! tolerance (`physics::newton_residual`: 3% of |h f| at one step per frame, less at smaller
//! steps), stalls at the floor of f32 forces, or δ is small. (A single iteration, as in
//! Baraff & Witkin, over-stretches stiff springs when a step rotates them far; iterating to
//! convergence keeps the step dissipative.)
//! Per spring (unit direction n, length l, rest L): −K = k [n nᵀ + max(0, 1 − L/l)(I − n nᵀ)],
//! the transverse term clamped so that a compressed spring cannot make the system indefinite, and
//! −D = c n nᵀ. A contact adds its penalty stiffness and damping along its normal; drag adds m γ I.
//! The system matrix is then symmetric positive definite, and so is each mass's 3 × 3 diagonal
//! block, which the preconditioner inverts (`block_of_mass`, `invert_block`; VBD solves with the
//! same block, src/cpu/vbd.rs). Pinned masses are filtered out of the
//! solve (their Δv stays zero). Friction enters through f only. Mass–mass contact has no
//! Jacobian here (a pair couples two masses along a normal that changes as they move), so scene
//! validation, the command line and the GPU backend refuse it with this integrator; were it
//! stepped here anyway, it would enter through f only, and stiff contacts would stall Newton.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::backward::{History, residual_work};
use super::cg::{cg_direction, cg_goes_on, cg_update, cg_update_unpreconditioned};
use super::chunks::{
    CHUNK, PARALLEL_MIN_MASSES, each_mass, each_mass_pair, max_chunks, sum_chunks,
};
use super::forces::{Gather, compute_forces};
use super::multigrid::Multigrid;
use super::system_blocks::{ContactTerms, SpringTerms, contacts_at, invert_block, own_block};
use crate::backend::StopFlags;
use crate::integrator::Integrator;
use crate::model::{Model, Spring, poses_at};
use crate::physics::{
    BackwardStep, NEWTON_BACKTRACKS, NEWTON_MAX_ITERATIONS, NEWTON_OVERSHOOT, NEWTON_STALL,
    NEWTON_TOLERANCE, Preconditioner, newton_floor, newton_residual, relative,
};
use crate::state::{Power, State};

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
    /// |h f − M Δv| / |h f| at the step's last iterate evaluated, and whether the step met its
    /// rule (Newton: tolerance, floor or a negligible update in its iterations; VBD_RESIDUAL).
    pub step_residual: f64,
    pub met: bool,
}

/// The system linearised at x₀.
#[derive(Debug, Default)]
pub struct Linearisation {
    pub(super) springs: Vec<SpringTerms>,
    contacts: Vec<Vec<ContactTerms>>,
}

/// Scratch for the solve, allocated once per backend.
#[derive(Debug, Default)]
pub struct ImplicitWork {
    pub(super) lin: Linearisation,
    acc: Vec<Vec3>,
    pub(super) b: Vec<Vec3>,
    pub(super) r: Vec<Vec3>,
    pub(super) z: Vec<Vec3>,
    pub(super) p: Vec<Vec3>,
    pub(super) ap: Vec<Vec3>,
    pub(super) dv: Vec<Vec3>,
    /// Each mass's diagonal block of the system, inverted: the preconditioner.
    pub(super) block_inv: Vec<Mat3>,
    /// Δv so far, and the iterate's state.
    dv_total: Vec<Vec3>,
    xk: Vec<Vec3>,
    vk: Vec<Vec3>,
    /// Large systems' preconditioner (block Jacobi without it).
    pub(super) multigrid: Option<Multigrid>,
    /// BDF2's last step start.
    history: History,
}

impl ImplicitWork {
    /// Scratch for `model`'s solves, preconditioned by `preconditioner` (block Jacobi where
    /// `model` has no coarse level to make).
    pub fn new(model: &Model, preconditioner: Preconditioner) -> Self {
        let n = model.mass_count();
        let zeros = || vec![Vec3::ZERO; n];
        Self {
            lin: Linearisation {
                springs: vec![SpringTerms::default(); model.spring_count()],
                contacts: vec![Vec::new(); n],
            },
            acc: zeros(),
            b: zeros(),
            r: zeros(),
            z: zeros(),
            p: zeros(),
            ap: zeros(),
            dv: zeros(),
            block_inv: vec![Mat3::IDENTITY; n],
            dv_total: zeros(),
            xk: zeros(),
            vk: zeros(),
            multigrid: match preconditioner {
                Preconditioner::Multigrid => Multigrid::new(model),
                Preconditioner::BlockJacobi => None,
            },
            history: History::default(),
        }
    }
}

/// a · b in f64, summed per chunk of masses and the chunks in order: the same result on any
/// number of threads.
fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
    sum_chunks(a.len(), |r| {
        a[r.clone()]
            .iter()
            .zip(&b[r])
            .map(|(p, q)| f64::from(p.dot(*q)))
            .sum()
    })
}

/// Σ over the springs of mass `i` of their stiffness and damping applied to p_i − p_j.
#[inline(always)]
fn spring_terms(model: &Model, lin: &Linearisation, p: &[Vec3], i: usize) -> Vec3 {
    let mut out = Vec3::ZERO;
    for nb in model.adjacency.of(i) {
        let j = nb.other as usize;
        let t = lin.springs[nb.spring as usize];
        // A pinned neighbour's Δv is zero: the filter removes its column.
        let pj = if model.inv_mass[j] == 0.0 {
            Vec3::ZERO
        } else {
            p[j]
        };
        let dp = p[i] - pj;
        let dn = t.n.dot(dp);
        out += (t.stiff_along + t.damp_along) * dn * t.n + t.stiff_across * (dp - dn * t.n);
    }
    out
}

/// (M − h D − h² K) p, filtered (pinned rows are zero).
pub fn apply_system(model: &Model, lin: &Linearisation, h: f32, p: &[Vec3], out: &mut [Vec3]) {
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    each_mass(out, |i, o| {
        if model.inv_mass[i] == 0.0 {
            *o = Vec3::ZERO;
            return;
        }
        let m = model.mass_kg[i];
        let mut v = m * (1.0 + h * drag) * p[i] + spring_terms(model, lin, p, i);
        for c in &lin.contacts[i] {
            v += (c.stiff + c.damp) * c.n.dot(p[i]) * c.n;
        }
        *o = v;
    });
}

fn linearise(
    model: &Model,
    springs: &[Spring],
    x: &[Vec3],
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
        contacts.clear();
        if model.inv_mass[i] == 0.0 {
            return;
        }
        contacts_at(&model.effects, &poses, x[i], model.mass_kg[i], h, |c| {
            contacts.push(c)
        });
    });
}

/// The system linearised at `x` (for the tests of its preconditioners).
#[cfg(test)]
pub(super) fn linearised_at(model: &Model, x: &[Vec3], h: f32) -> Linearisation {
    let mut lin = Linearisation {
        springs: vec![SpringTerms::default(); model.spring_count()],
        contacts: vec![Vec::new(); model.mass_count()],
    };
    linearise(model, &model.springs, x, 0.0, h, &mut lin);
    lin
}

/// One step of `dt` of `integrator`, implicit Euler or BDF2 (`physics::BackwardStep`): backward
/// Euler from the step's blended start. The ledger takes the dissipation rates at the converged
/// iterate, the end of the step, over the whole step (backward quadrature, as the scheme itself).
pub fn implicit_step(
    model: &Model,
    gather: &mut Gather,
    state: &mut State,
    w: &mut ImplicitWork,
    (integrator, dt): (Integrator, f32),
    stop: &StopFlags,
) -> SolveStats {
    let step = BackwardStep::of(integrator, dt, w.history.steps_taken());
    let h = step.solve_secs;
    let t_end = state.time_secs + f64::from(dt);
    let mut stats = SolveStats::default();
    let mut power = Power::default();
    let mut scale = 0.0f64;
    let order = integrator.order();
    let tolerance = newton_residual(f64::from(dt), order);
    let floor = newton_floor(f64::from(dt), order);
    let mut last_residual = f64::INFINITY;
    // BDF2 keeps its history, and its Newton heeds its residual's work (NEWTON_WORK_SHARE).
    let keep = integrator == Integrator::Bdf2;
    w.history
        .implicit_blend(step, keep, &mut state.x, &mut state.v);
    implicit_begin(&mut w.dv_total);
    let mut halvings = 0;
    for _ in 0..NEWTON_MAX_ITERATIONS {
        if stop.asked() {
            break;
        }
        implicit_iterate(&state.x, &state.v, &w.dv_total, h, (&mut w.xk, &mut w.vk));
        power = compute_forces(model, gather, &w.xk, &w.vk, t_end, h, &mut w.acc);
        linearise(model, gather.springs(), &w.xk, t_end, h, &mut w.lin);
        let (residual, momentum) = implicit_rhs(model, w, h);
        let work_ok = !keep || residual_work(model, &w.vk, &w.b) <= 0.0;
        if scale == 0.0 {
            // |h f| at the first iterate (Δv = 0: the first residual): what Newton's rule is
            // relative to.
            scale = momentum;
        }
        stats.step_residual = relative(residual, scale);
        if (newton_done(residual, scale, tolerance)
            || newton_stalled(residual, last_residual, scale, floor))
            && work_ok
        {
            stats.met = true;
            break;
        }
        if newton_overshot(residual, last_residual, halvings) {
            halvings += 1;
            stats.newton += 1;
            newton_halve(&mut w.dv, &mut w.dv_total);
            continue;
        }
        halvings = 0;
        last_residual = residual;
        let (iterations, residual) = solve(model, w, (h, residual), stop);
        stats.newton += 1;
        stats.iterations += iterations;
        stats.residual = stats.residual.max(residual);
        // A solve the stop cut short says nothing of convergence: the step ends unmet.
        if stop.asked() {
            break;
        }
        if newton_update(&w.dv, &mut w.dv_total) {
            stats.met = true;
            break;
        }
    }
    implicit_final(state, &w.dv_total, h);
    state.ledger.accumulate(&power, f64::from(dt));
    state.time_secs = t_end;
    state.steps += 1;
    stats
}

/// Δv starts at zero. (Starting from the last step's Δv gained nothing on jello at 1/60 s once
/// the tolerance was measured against |h f| at Δv = 0, and on a very stiff chain swinging at
/// 1/60 s Newton then wandered and the chain gained energy: BENCHMARKS.md, "Implicit Euler and
/// VBD at one step per frame".)
pub fn implicit_begin(dv_total: &mut [Vec3]) {
    dv_total.fill(Vec3::ZERO);
}

/// The Newton iterate (x + h (v + Δv), v + Δv).
pub fn implicit_iterate(
    x: &[Vec3],
    v: &[Vec3],
    dv_total: &[Vec3],
    h: f32,
    (xk, vk): (&mut [Vec3], &mut [Vec3]),
) {
    each_mass_pair(xk, vk, |i, xk, vk| {
        *vk = v[i] + dv_total[i];
        *xk = x[i] + h * *vk;
    });
}

/// Mass `i`'s diagonal block of the system M − h D − h² K at the linearisation: its mass (with
/// drag), its contacts along their normals, and each of its springs. Symmetric positive
/// definite: the transverse spring term is clamped at zero by `linearise`.
#[inline(always)]
pub(super) fn block_of_mass(
    model: &Model,
    lin: &Linearisation,
    h: f32,
    drag: f32,
    i: usize,
) -> Mat3 {
    let mut d = own_and_contacts(model, lin, h, drag, i);
    for nb in model.adjacency.of(i) {
        d += lin.springs[nb.spring as usize].block();
    }
    d
}

/// Newton's right-hand side b = h f(x, v) − M Δv, and each mass's inverted diagonal block for the
/// preconditioner. Returns |b| and |h f|, the step's momentum change at this iterate.
pub fn implicit_rhs(model: &Model, w: &mut ImplicitWork, h: f32) -> (f64, f64) {
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    let ImplicitWork {
        lin,
        acc,
        b,
        block_inv,
        dv_total,
        ..
    } = w;
    let (lin, acc, dv_total) = (&*lin, &*acc, &*dv_total);
    each_mass(b, |i, b| {
        *b = if model.inv_mass[i] == 0.0 {
            Vec3::ZERO
        } else {
            let m = model.mass_kg[i];
            h * m * acc[i] - m * dv_total[i]
        };
    });
    each_mass(block_inv, |i, inv| {
        *inv = if model.inv_mass[i] == 0.0 {
            Mat3::IDENTITY
        } else {
            invert_block(block_of_mass(model, lin, h, drag, i))
        };
    });
    // |h f| = |h M a| over the movable masses (a pinned mass's acceleration is zero).
    let momentum = sum_chunks(acc.len(), |r| {
        model.mass_kg[r.clone()]
            .iter()
            .zip(&acc[r])
            .map(|(m, a)| f64::from((h * m * *a).length_squared()))
            .sum()
    })
    .sqrt();
    (dot(b, b).sqrt(), momentum)
}

/// Δv += δ; returns whether Newton has converged: the update is small against Δv (or Δv is
/// below 1e-7 m/s).
pub fn newton_update(dv: &[Vec3], dv_total: &mut [Vec3]) -> bool {
    let largest = |v: &[Vec3]| {
        max_chunks(v.len(), |r| {
            v[r].iter()
                .map(|d| f64::from(d.length()))
                .fold(0.0, f64::max)
        })
    };
    let step = largest(dv);
    each_mass(dv_total, |i, total| *total += dv[i]);
    let size = largest(dv_total);
    step <= NEWTON_TOLERANCE * size || step < 1e-7
}

/// Whether the last update left Newton's residual `residual` above `physics::NEWTON_OVERSHOOT`
/// times the one it started from (`last`), with fewer than `physics::NEWTON_BACKTRACKS`
/// halvings of it so far: it is then halved (`newton_halve`) rather than solved from.
pub fn newton_overshot(residual: f64, last: f64, halvings: u32) -> bool {
    residual > NEWTON_OVERSHOOT * last && halvings < NEWTON_BACKTRACKS
}

/// The last update δ is halved: δ ← δ / 2, Δv ← Δv − δ.
pub fn newton_halve(dv: &mut [Vec3], dv_total: &mut [Vec3]) {
    each_mass_pair(dv, dv_total, |_, d, total| {
        *d *= 0.5;
        *total -= *d;
    });
}

/// Whether Newton's residual `residual` (|h f − M Δv| at the current iterate) is small enough
/// to end the step there: at most `tolerance` (`physics::newton_residual` of the step) of the
/// step's momentum change `scale`.
pub fn newton_done(residual: f64, scale: f64, tolerance: f64) -> bool {
    residual <= tolerance * scale
}

/// Whether Newton's residual `residual` has stalled at the floor of f32 forces: below `floor`
/// (`physics::newton_floor` of the step) of the step's momentum change `scale`, and not halved
/// since the last iterate's (`last`). The step then ends at the current iterate.
pub fn newton_stalled(residual: f64, last: f64, scale: f64, floor: f64) -> bool {
    residual <= floor * scale && residual > NEWTON_STALL * last
}

/// The step ends at the last iterate.
pub fn implicit_final(state: &mut State, dv_total: &[Vec3], h: f32) {
    each_mass_pair(&mut state.x, &mut state.v, |i, x, v| {
        *v += dv_total[i];
        *x += h * *v;
    });
}

/// Preconditioned conjugate gradients for the system at the current linearisation, from δ = 0,
/// into `w.dv`, until `cg_goes_on` says or `stop` is asked, `b_norm` being |b|. Returns the
/// iterations and |r| / |b|.
fn solve(
    model: &Model,
    w: &mut ImplicitWork,
    (h, b_norm): (f32, f64),
    stop: &StopFlags,
) -> (u32, f64) {
    let ImplicitWork {
        lin,
        b,
        r,
        z,
        p,
        ap,
        dv,
        block_inv,
        multigrid,
        ..
    } = w;
    dv.fill(Vec3::ZERO);
    r.copy_from_slice(b);
    if b_norm == 0.0 {
        return (0, 0.0);
    }
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    if let Some(mg) = multigrid.as_mut() {
        mg.linearise(
            |i| own_and_contacts(model, lin, h, drag, i),
            |s| lin.springs[s].block(),
        );
        mg.cycle(
            block_inv,
            |p, out| apply_system(model, lin, h, p, out),
            r,
            z,
        );
    } else {
        let (r, block_inv) = (&*r, &*block_inv);
        each_mass(z, |i, z| *z = block_inv[i] * r[i]);
    }
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    let mut iterations = 0;
    loop {
        let residual = dot(r, r).sqrt() / b_norm;
        if !cg_goes_on(residual, iterations) || stop.asked() {
            return (iterations, residual);
        }
        iterations += 1;
        apply_system(model, lin, h, p, ap);
        let pap = dot(p, ap);
        if pap <= 0.0 || !pap.is_finite() {
            return (iterations, residual);
        }
        let alpha = (rz / pap) as f32;
        if let Some(mg) = multigrid.as_mut() {
            cg_update_unpreconditioned(alpha, (p, ap), (dv, r));
            mg.cycle(
                block_inv,
                |p, out| apply_system(model, lin, h, p, out),
                r,
                z,
            );
        } else {
            cg_update(alpha, (p, ap, block_inv), (dv, r, z));
        }
        let rz_next = dot(r, z);
        let beta = (rz_next / rz) as f32;
        rz = rz_next;
        cg_direction(beta, z, p);
    }
}

/// Mass `i`'s own block: its mass with drag, and its contacts, without its springs
/// (`block_of_mass` adds them; the multigrid hierarchy takes them as its edges).
pub(super) fn own_and_contacts(
    model: &Model,
    lin: &Linearisation,
    h: f32,
    drag: f32,
    i: usize,
) -> Mat3 {
    let mut d = own_block(model.mass_kg[i], h, drag);
    for c in &lin.contacts[i] {
        d += c.block();
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{NEWTON_FLOOR, NEWTON_RESIDUAL};

    /// The hair scene at its own step: a stiff strand hanging under gravity, whose residual f32
    /// forces cannot take below about 3e-3 of the step's first. Newton once ran all 10
    /// iterations of every step there, each moving Δv by rounding noise; the residual rule ends
    /// it in a few.
    #[test]
    fn newton_stops_at_the_floor_of_f32_forces_on_hair() {
        let crate::prepare::Planned {
            settings, model, ..
        } = crate::prepare::planned("hair").expect("the built-in hair scene is planned");
        let mut gather = Gather::new(&model);
        let mut work = ImplicitWork::new(&model, Preconditioner::BlockJacobi);
        let mut state = model.initial.clone();
        let steps = 120;
        let newton: u32 = (0..steps)
            .map(|_| {
                let s = implicit_step(
                    &model,
                    &mut gather,
                    &mut state,
                    &mut work,
                    (Integrator::Implicit, settings.dt_secs as f32),
                    &StopFlags::default(),
                );
                assert!(s.newton < NEWTON_MAX_ITERATIONS, "{s:?}");
                s.newton
            })
            .sum();
        let mean = f64::from(newton) / f64::from(steps);
        assert!(mean <= 3.0, "{mean} Newton iterations per step");
        assert!(state.x.iter().all(|x| x.is_finite()));
    }

    #[test]
    fn newton_ends_on_its_residual_and_each_solve_at_a_share_of_it() {
        assert!(newton_done(0.0299, 1.0, 0.03));
        assert!(!newton_done(0.0301, 1.0, 0.03));
        // The tolerance: 3% at one step per frame, as the step to the scheme's order below it.
        assert_eq!(newton_residual(1.0 / 60.0, 1), NEWTON_RESIDUAL);
        assert_eq!(newton_residual(1.0, 2), NEWTON_RESIDUAL);
        assert!((newton_residual(1.0 / 120.0, 1) - NEWTON_RESIDUAL / 2.0).abs() < 1e-12);
        assert!((newton_residual(1.0 / 120.0, 2) - NEWTON_RESIDUAL / 4.0).abs() < 1e-12);
        // Stalled: below the floor and less than halved; not while falling fast, nor above it.
        let floor = NEWTON_FLOOR;
        assert!(newton_stalled(2e-3, 3e-3, 1.0, floor));
        assert!(!newton_stalled(1e-4, 1.0, 1.0, floor));
        assert!(!newton_stalled(0.5, 0.6, 1.0, floor));
        assert!(!newton_stalled(1.0, f64::INFINITY, 1.0, floor));
        // At one step per frame the floor is three times the tolerance; at small steps, the
        // floor of f32 forces.
        assert!((newton_floor(1.0 / 60.0, 1) - 2.0 * NEWTON_RESIDUAL).abs() < 1e-12);
        assert_eq!(newton_floor(1e-4, 1), NEWTON_FLOOR);
        assert!(newton_stalled(
            0.045,
            0.046,
            1.0,
            newton_floor(1.0 / 60.0, 1)
        ));
        // A solve stops at a tenth of the Newton residual it started from, or at its cap.
        use crate::physics::{CG_FORCING, CG_MAX_ITERATIONS};
        assert!(cg_goes_on(CG_FORCING * 1.01, 0));
        assert!(!cg_goes_on(CG_FORCING * 0.99, 0));
        assert!(!cg_goes_on(1.0, CG_MAX_ITERATIONS));
    }
}
