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

use glam::{Mat3, Vec3, Vec4};

use super::backward::residual_work;
use super::cg::{
    cg_direction, cg_forcing, cg_goes_on, cg_update, cg_update_unpreconditioned, usable_curvature,
};
use super::chunks::{each_mass, each_mass_pair};
use super::forces::{Gather, compute_forces};
use super::implicit_work::{ImplicitWork, Linearisation, SolveStats, linearise};
use super::newton_rules::{
    NewtonRules, newton_converged, newton_done, newton_overshot, newton_scale, newton_stalled,
    newton_wandered, relative,
};
use super::solver_sums::{group_max, group_reduce};
use super::system_blocks::{block_times, invert_block, own_block};
use crate::backend::StopFlags;
use crate::integrator::Integrator;
use crate::model::Model;
use crate::physics::NEWTON_MAX_ITERATIONS;
use crate::state::{Power, State};

/// (M − h D − h² K) p, filtered (pinned rows are zero).
pub fn apply_system(model: &Model, lin: &Linearisation, h: f32, p: &[Vec3], out: &mut [Vec3]) {
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    each_mass(out, |i, o| *o = system_times(model, lin, h, drag, p, i));
}

/// Row `i` of (M − h D − h² K) p: its own term, then each spring's in CSR order, then its
/// contacts', added as shaders/implicit_terms.wgsl's `apply_system_at` adds them.
#[inline(always)]
fn system_times(
    model: &Model,
    lin: &Linearisation,
    h: f32,
    drag: f32,
    p: &[Vec3],
    i: usize,
) -> Vec3 {
    if model.inv_mass[i] == 0.0 {
        return Vec3::ZERO;
    }
    let pi = p[i];
    let mut out = model.mass_kg[i] * (1.0 + h * drag) * pi;
    for nb in model.adjacency.of(i) {
        let j = nb.other as usize;
        // A pinned neighbour's Δv is zero: the filter removes its column.
        let pj = if model.inv_mass[j] == 0.0 {
            Vec3::ZERO
        } else {
            p[j]
        };
        let t = lin.springs[nb.spring as usize];
        out = t.add_times(out, pi - pj);
    }
    if model.effects.has_contact() {
        out += lin.contacts[i].times(pi);
    }
    out
}

/// One step of `dt` of `integrator`, implicit Euler or BDF2 (`physics::BackwardStep`): backward
/// Euler from the step's blended start. The ledger takes the dissipation rates at the converged
/// iterate, the end of the step, over the whole step (backward quadrature, as the scheme itself).
/// Each iterate's residual is judged against its own momentum change (`newton_scale`). A step
/// whose iterations run out short of Newton's rule, wandering (`newton_wandered`), ends at the
/// iterate with the least residual it solved from after its first, with its rates. A BDF2 step
/// whose blend, kept out of the colliders, would press a spring hard restarts with implicit
/// Euler (`backward::blend_presses`), its solves taken to `CG_FORCING_AT_RESTART`.
pub fn implicit_step(
    model: &Model,
    gather: &mut Gather,
    state: &mut State,
    w: &mut ImplicitWork,
    integrator: Integrator,
    dt: f32,
    stop: &StopFlags,
) -> SolveStats {
    let t_end = state.time_secs + f64::from(dt);
    let mut stats = SolveStats::default();
    let mut power = Power::default();
    let rules = NewtonRules::of(f64::from(dt), integrator.order(), w.weight_n);
    let mut last_residual = f32::MAX;
    // BDF2 keeps its history, and its Newton heeds its residual's work (NEWTON_WORK_SHARE).
    let keep = integrator.scheme().history();
    let (step, restarted) = w.history.start_step(
        (model, gather.springs()),
        (integrator, dt, t_end),
        (&mut state.x, &mut state.v),
    );
    let h = step.solve_secs;
    let forcing = cg_forcing(restarted);
    implicit_begin(&mut w.dv_total);
    let mut halvings = 0;
    // The iterate with the least residual that Newton solved from after its first (Δv = 0, no
    // solution at all): that residual, relative to its own scale, and its rates.
    let mut best = (f32::MAX, 0.0, Power::default());
    let mut last_evaluated = f32::MAX;
    for k in 0..NEWTON_MAX_ITERATIONS {
        if stop.asked() {
            break;
        }
        implicit_iterate(&state.x, &state.v, &w.dv_total, h, (&mut w.xk, &mut w.vk));
        power = compute_forces(model, gather, &w.xk, &w.vk, t_end, h, &mut w.acc);
        linearise(
            model,
            gather.springs(),
            (&w.xk, &w.vk),
            t_end,
            h,
            &mut w.lin,
        );
        let sums = implicit_rhs(model, w, h, keep);
        let residual = sums.y.sqrt();
        let scale = newton_scale(sums.z.sqrt(), h, rules.weight_n);
        let share = relative(residual, scale);
        stats.step_residual = f64::from(share);
        last_evaluated = residual;
        if (newton_done(residual, scale, rules.tolerance)
            || newton_stalled(residual, last_residual, scale, rules.floor))
            && (!keep || sums.w <= 0.0)
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
        if k > 0 && residual <= best.0 {
            best = (residual, share, power);
            w.best_dv.copy_from_slice(&w.dv_total);
        }
        let (iterations, residual) = solve(model, w, h, (residual, sums.x), (forcing, stop));
        stats.newton += 1;
        stats.iterations += iterations;
        stats.residual = stats.residual.max(f64::from(residual));
        // A solve the stop cut short says nothing of convergence: the step ends unmet.
        if stop.asked() {
            break;
        }
        if newton_update(&w.dv, &mut w.dv_total) {
            stats.met = true;
            break;
        }
    }
    if !stats.met && newton_wandered(last_evaluated, best.0) {
        // Short of its rule and wandering, the step ends where it was best, not at its last
        // update, which no evaluation judged (nor did the ledger's rates, which were the last
        // iterate's). Newton can alternate between an iterate clear of a collider and one deep
        // in it (it did at every contact onset while the damper switched on at full strength on
        // touching), and ending on the deep one stored energy in the contact from nowhere
        // (docs/stability.md).
        w.dv_total.copy_from_slice(&w.best_dv);
        power = best.2;
        stats.step_residual = f64::from(best.1);
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
        d = lin.springs[nb.spring as usize].add_block(d);
    }
    d
}

/// Newton's right-hand side b = h f(x, v) − M Δv, and each mass's inverted diagonal block for the
/// preconditioner. Returns the sums of (b·B⁻¹b, |b|², |h f|², and with `work` BDF2's residual
/// work, `backward::residual_work`) over the masses, as `implicit_rhs_at` returns them to the
/// one-workgroup step's sums.
pub fn implicit_rhs(model: &Model, w: &mut ImplicitWork, h: f32, work: bool) -> Vec4 {
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    let ImplicitWork {
        lin,
        acc,
        b,
        z,
        block_inv,
        dv_total,
        vk,
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
    // Block Jacobi's z = B⁻¹b, the solve's start (the multigrid cycle makes its own).
    let (b, block_inv) = (&*b, &*block_inv);
    each_mass(z, |i, z| *z = block_times(block_inv[i], b[i]));
    let (z, vk) = (&*z, &*vk);
    group_reduce(b.len(), |i| {
        if model.inv_mass[i] == 0.0 {
            return Vec4::ZERO;
        }
        let (bi, m) = (b[i], model.mass_kg[i]);
        let hf = h * m * acc[i];
        let z = z[i];
        let w = if work {
            residual_work(m, vk[i], bi)
        } else {
            0.0
        };
        Vec4::new(bi.dot(z), bi.dot(bi), hf.dot(hf), w)
    })
}

/// Δv += δ; returns whether Newton has converged (`newton_rules::newton_converged`).
pub fn newton_update(dv: &[Vec3], dv_total: &mut [Vec3]) -> bool {
    let step = group_max(dv.len(), |i| Vec4::splat(dv[i].length())).x;
    each_mass(dv_total, |i, total| *total += dv[i]);
    let size = group_max(dv_total.len(), |i| Vec4::splat(dv_total[i].length())).x;
    newton_converged(step, size)
}

/// The last update δ is halved: δ ← δ / 2, Δv ← Δv − δ.
pub fn newton_halve(dv: &mut [Vec3], dv_total: &mut [Vec3]) {
    each_mass_pair(dv, dv_total, |_, d, total| {
        *d *= 0.5;
        *total -= *d;
    });
}

/// The step ends at the last iterate.
pub fn implicit_final(state: &mut State, dv_total: &[Vec3], h: f32) {
    each_mass_pair(&mut state.x, &mut state.v, |i, x, v| {
        *v += dv_total[i];
        *x += h * *v;
    });
}

/// Preconditioned conjugate gradients for the system at the current linearisation, from δ = 0,
/// into `w.dv`, until `cg_goes_on` says at the step's `forcing` or `stop` is asked, given |b|
/// and b·B⁻¹b (block Jacobi's first r·z). Returns the iterations and |r| / |b|, as
/// `solve_in_group` (implicit_group.wgsl).
fn solve(
    model: &Model,
    w: &mut ImplicitWork,
    h: f32,
    (b_norm, rz): (f32, f32),
    (forcing, stop): (f32, &StopFlags),
) -> (u32, f32) {
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
    let sum = |a: &[Vec3], b: &[Vec3]| group_reduce(a.len(), |i| Vec4::splat(a[i].dot(b[i]))).x;
    let mut rz = rz;
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
        rz = sum(r, z);
    }
    // Block Jacobi's z = B⁻¹r is implicit_rhs's, r being b.
    p.copy_from_slice(z);
    let mut residual = 1.0f32;
    let mut iterations = 0;
    while cg_goes_on(residual, iterations, forcing) && !stop.asked() {
        iterations += 1;
        apply_system(model, lin, h, p, ap);
        let pap = sum(p, ap);
        if !usable_curvature(pap) {
            break;
        }
        let alpha = rz / pap;
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
        let (r, z) = (&*r, &*z);
        let sums = group_reduce(r.len(), |i| {
            Vec4::new(r[i].dot(z[i]), r[i].dot(r[i]), 0.0, 0.0)
        });
        let beta = sums.x / rz;
        rz = sums.x;
        residual = sums.y.sqrt() / b_norm;
        cg_direction(beta, z, p);
    }
    (iterations, residual)
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
    let own = own_block(model.mass_kg[i], h, drag);
    if model.effects.has_contact() {
        own + lin.contacts[i].block()
    } else {
        own
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::Preconditioner;

    /// The hair scene at its own step: a stiff strand hanging under gravity, whose residual f32
    /// forces cannot take below about 3e-3 of the step's first. Newton once ran all 10
    /// iterations of every step there, each moving Δv by rounding noise; the residual rule ends
    /// it in a few.
    #[test]
    fn newton_stops_at_the_floor_of_f32_forces_on_hair() {
        let crate::run::prepare::Planned {
            settings, model, ..
        } = crate::run::prepare::planned("hair").expect("the built-in hair scene is planned");
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
                    Integrator::Implicit,
                    settings.dt_secs as f32,
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
}
