//! Implicit Euler's stopping rules and iteration caps: the CPU backend stops by them, and the GPU
//! backend compiles them into its shaders (`override` constants) and sizes its budgets by them, so
//! that both backends stop a solve alike.

/// Inexact Newton: each linear solve stops once its residual is this share of the Newton
/// residual it started from (it went to 1e-4 of the step's |h f|). Solving further buys little,
/// as the system is only the linearisation at the current iterate (BENCHMARKS.md, "Implicit
/// Euler and VBD at one step per frame").
pub const CG_FORCING: f64 = 0.1;
/// The forcing of a step BDF2 restarts with implicit Euler across an impact
/// (`BackwardStep::restarted`): its first iterate carries a falling body a whole step deep into
/// the ground, and the first update's linear model is far from the step's solution there, so a
/// solve stopped at `CG_FORCING` left the lattice crushed: in a trial build the jello dropped at
/// 1/10 s ended its landing with 18 J of elastic energy from its 7.6 J start; solved to this
/// share it lands with 0.02 J (docs/stability.md). Such steps are a few in a run.
pub const CG_FORCING_AT_RESTART: f64 = 1e-3;
/// BDF2 restarts a step where keeping its blend out of the colliders would move a mass back by
/// more than this share of its shortest spring's rest length (`cpu::backward::blend_presses`):
/// past half, the lowest layer of a landing body starts pressed into the one above, and the
/// jello gained energy at steps from 6.5e-2 to 9e-2 s; below it, the rule keeps BDF2 second
/// order away from the contact (docs/stability.md).
pub const RESTART_PRESS_SHARE: f32 = 0.5;
/// Newton stops when the update is this small relative to Δv (or Δv is below 1e-7 m/s).
pub const NEWTON_TOLERANCE: f64 = 1e-4;
/// Newton iteration cap per step.
pub const NEWTON_MAX_ITERATIONS: u32 = 10;
/// At one step per frame (`NEWTON_RESIDUAL_STEP_SECS`), Newton stops once its residual
/// |h f − M Δv| is at most this share of the step's momentum change |h f| (taken at the iterate
/// judged, and at least its weight's impulse: `cpu::newton_rules::newton_scale`): the step's
/// equations hold to 3%. Measured on jello and cloth at 1/60 s over 1 s, when the scale was the
/// first iterate's |h f|, positions then differed from a solve to the f32 floor by 2.7e-2 and
/// 2.1e-2 m RMS, against 1.2 and 0.09 m between implicit Euler at 1/60 s and semi-implicit Euler
/// at the scenes' own steps (2% and a quarter of the scheme's own error), at a third and a fifth
/// of the cost.
pub const NEWTON_RESIDUAL: f64 = 3e-2;
/// The step `NEWTON_RESIDUAL` is set for.
pub const NEWTON_RESIDUAL_STEP_SECS: f64 = 1.0 / 60.0;
/// Newton also stops once its residual is below this share of |h f| and the last update did
/// not halve it (`NEWTON_STALL`): the residual has reached the floor of f32 forces (a stiff
/// spring's tension cancelling gravity leaves it about 3e-3 of |h f| on the hair scene), where
/// further updates are rounding noise. Without this rule such a step ran all
/// NEWTON_MAX_ITERATIONS iterations, each moving Δv by noise.
pub const NEWTON_FLOOR: f64 = 1e-2;
/// See `NEWTON_FLOOR`.
pub const NEWTON_STALL: f64 = 0.5;
/// A Newton update that leaves the residual |h f − M Δv| more than `NEWTON_OVERSHOOT` times
/// larger than it found it is halved, and the iterate evaluated again, up to this many times
/// before Newton goes on from where it is (a backtracking line search on the residual; each
/// evaluation counts against `NEWTON_MAX_ITERATIONS`). Newton's system clamps a compressed
/// spring's transverse stiffness (so that it stays definite), so on springs very stiff against
/// the step its update can overshoot. On `tests/hard_cases.rs`'s chain at k = 5e4 (k h²/m ≈
/// 1.4e4 at 1/60 s), from 200 starts moved by one f32 step, implicit Euler gained energy in 15
/// (to 165 times the start) and BDF2 in 23 (to 894 times) without it, and 0 of either with it;
/// at k = 1e5 implicit Euler still did in 9 of 200 (BENCHMARKS.md, "A real driver's rounding").
pub const NEWTON_BACKTRACKS: u32 = 2;
/// How much larger than the last a residual must be to count as overshot: a margin above the
/// rounding of the sums, which the GPU takes in f32 and the CPU in f64, so that both backends
/// halve the same updates (with none, a residual at the floor of f32 forces, equal from one
/// iterate to the next, halved on one backend and not the other).
pub const NEWTON_OVERSHOOT: f64 = 1.1;
/// At a large step the floor of f32 forces can sit above the tolerance itself: on a 256 × 256
/// cloth at 1/60 s (positions near 1.5 m, whose f32 spacing times the springs' stiffness is a
/// tenth of a mass's weight) Newton's residual fell to 4.3–4.5% of |h f| and stayed there for
/// the seven iterations left to it. So Newton also counts as stalled below this many times the
/// step's tolerance (`newton_floor`). Three times left `tests/hard_cases.rs`'s very stiff chain
/// swinging 2.0 mm after 10 s on lavapipe (its bound is 2 mm); twice leaves 0.95 mm (0.52 mm
/// with the floor alone).
pub const NEWTON_FLOOR_PER_TOLERANCE: f64 = 2.0;

/// The residual, relative to |h f|, below which Newton ends a step once an iteration fails to
/// halve it (`NEWTON_FLOOR`, or `NEWTON_FLOOR_PER_TOLERANCE` times the step's tolerance where
/// that is more): 6% at one step per frame, 1% from a sixth of it down.
pub fn newton_floor(h_secs: f64, order: u32) -> f64 {
    NEWTON_FLOOR.max(NEWTON_FLOOR_PER_TOLERANCE * newton_residual(h_secs, order))
}

/// The 2-norm over the movable masses of their weights, |g| (Σ m²)^½ in newtons, rounded to f32
/// once (the GPU takes it as the `WEIGHT_N` override). Times the step it is the impulse that
/// gravity alone gives a step, the least momentum change a Newton iterate is judged against
/// (`newton_scale`): a body at rest, whose forces cancel, is not held to a residual of zero.
pub fn weight_norm_n(model: &crate::model::Model) -> f32 {
    let g = model
        .effects
        .gravity_m_per_s2
        .map_or(0.0, |g| g.as_dvec3().length());
    let sum: f64 = model
        .mass_kg
        .iter()
        .zip(&model.inv_mass)
        .filter(|&(_, &w)| w != 0.0)
        .map(|(&m, _)| f64::from(m) * f64::from(m))
        .sum();
    (g * sum.sqrt()) as f32
}

/// Newton's residual tolerance at step `h_secs` for a scheme of order `order`, relative to
/// |h f|: `NEWTON_RESIDUAL` at one step per frame, and as (h / (1/60 s))^order below it. The
/// scheme's own error per step falls as h^(order + 1) and |h f| as h, so the solver's error
/// stays a fixed share of the scheme's: with 3% at every step, implicit Euler's error on hair
/// stopped halving with the step between 8e-4 and 2e-4 s, and at 2e-4 s the hair gained energy.
pub fn newton_residual(h_secs: f64, order: u32) -> f64 {
    let order = i32::try_from(order).unwrap_or(i32::MAX);
    NEWTON_RESIDUAL * (h_secs / NEWTON_RESIDUAL_STEP_SECS).min(1.0).powi(order)
}

/// BDF2 has no numerical damping to absorb what an inexact Newton step leaves: on
/// `tests/hard_cases.rs`'s very stiff chain at 1/60 s (k h²/m ≈ 1.4e4) its energy grew from the
/// 25th step, spiking to 6 000 times its start by the 467th, while with every solve taken to
/// 1e-6 it decayed as implicit Euler's does. A step whose Newton residual r = h f − M Δv is
/// left over acts as an impulse −r on the masses, doing work −v·r on the step's velocities v.
/// So BDF2's Newton also waits (its stall rule too) until that work is at most this share of
/// their kinetic energy: Σ (−v·r − share · ½ m v²) ≤ 0 over the movable masses. With shares of
/// 1e-2, 3e-3 and 1e-3 the chain's energy decayed as implicit Euler's on the CPU; with 1e-2 and
/// the stall rule left free it spiked to 0.68 J (from 0.20) at the 143rd step. The GPU sums the
/// work in f32, and on lavapipe one step still took the chain 16% above its start (BENCHMARKS.md,
/// "BDF2: second order at one step per frame").
pub const NEWTON_WORK_SHARE: f64 = 1e-2;

/// BDF2's weights: x̂ = x + (x − x₋₁) / 3 (that is (4x − x₋₁) / 3), and its solve's step 2h / 3.
const BDF2_HISTORY: f32 = 1.0 / 3.0;
const BDF2_SOLVE_SHARE: f64 = 2.0 / 3.0;

/// One step of the backward schemes, as both backends take it: from the blend
/// x̂ = x + history (x − x₋₁), v̂ = v + history (v − v₋₁), where x₋₁ and v₋₁ are the last
/// step's start, backward Euler over `solve_secs`,
///   v₁ = v̂ + M⁻¹ f(x₁, v₁) solve_secs,   x₁ = x̂ + solve_secs v₁,
/// with the forces at the step's end, t + `h`. Implicit Euler is history 0 and the whole step;
/// BDF2, (3/2) x₁ − 2 x + (1/2) x₋₁ = h v₁ and the same for v, is history 1/3 and two thirds
/// of it, and starts with an implicit Euler step (it has no x₋₁ yet). The dissipation ledger
/// takes the rates at the end over the whole step h either way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackwardStep {
    pub h_secs: f32,
    pub solve_secs: f32,
    pub history: f32,
}

impl BackwardStep {
    /// Step `taken` (0 the run's first) of `integrator` at `dt`: BDF2 from its second step on,
    /// else backward Euler.
    pub fn of(integrator: crate::integrator::Integrator, dt: f32, taken: u64) -> Self {
        if integrator.scheme().history() && taken > 0 {
            Self {
                h_secs: dt,
                solve_secs: (f64::from(dt) * BDF2_SOLVE_SHARE) as f32,
                history: BDF2_HISTORY,
            }
        } else {
            Self {
                h_secs: dt,
                solve_secs: dt,
                history: 0.0,
            }
        }
    }

    /// Whether `integrator` on a scene with `effects` keeps its blend out of the colliders and
    /// may restart across impacts (BDF2 with the ground or a collider,
    /// `cpu::backward::blend_presses`): the GPU then compiles and runs its restart test.
    pub fn restarts_at_impacts(
        integrator: crate::integrator::Integrator,
        effects: &crate::model::Effects,
    ) -> bool {
        integrator.scheme().history() && effects.has_contact()
    }

    /// The same step taken as implicit Euler from the step's own start: how BDF2 restarts across
    /// an impact (`cpu::backward::blend_presses`), as multistep methods restart at a
    /// discontinuity. Its history is kept for the next step, which blends again.
    pub fn restarted(self) -> Self {
        Self {
            h_secs: self.h_secs,
            solve_secs: self.h_secs,
            history: 0.0,
        }
    }
}
/// VBD's fixed sweeps count as having solved a step when they leave backward Euler's residual
/// |h f − M Δv| at most this share of the step's momentum change |h f| (VBD has no rule of its
/// own: it stops after its sweeps, converged or not). A step above it is reported as Newton's
/// steps short of their tolerance are (`StepStats::rule`).
pub const VBD_RESIDUAL: f64 = 0.5;

/// How implicit Euler's and BDF2's sums over the masses are taken on a CPU adapter (lavapipe),
/// and so on the CPU backend (`cpu/solver_sums.rs`), so that the two take every decision alike
/// and agree bit for bit: `sum_groups(n)` workgroups of `SUM_LANES` threads, thread t adding
/// the masses t, t + T, t + 2T, … (T the threads of all the groups) in f32 from zero, each
/// workgroup adding its threads' sums in order, and the workgroups' sums added in eight strided
/// shares, those in order (shaders/solver_sums.wgsl's `store_grid_partial` and `grid_total`).
/// A system the one-workgroup step takes (at most `gpu::limits::IN_GROUP_MAX_MASSES`) is one
/// group, whose step's sums are then the same. On lavapipe's SIMD lanes 8 threads ran hair's
/// step 2x faster than 64 (`gpu/sizing.rs`'s `group_threads`).
pub const SUM_LANES: u32 = 8;

/// Masses per workgroup of those sums, and the most workgroups (see `SUM_LANES`).
pub const SUM_GROUP_MASSES: usize = 2048;
pub const SUM_GROUPS_MOST: usize = 64;

/// Workgroups of the sums over `masses` masses on a CPU adapter (see `SUM_LANES`).
pub fn sum_groups(masses: usize) -> usize {
    masses.div_ceil(SUM_GROUP_MASSES).clamp(1, SUM_GROUPS_MOST)
}

/// Iteration cap: a step that needs more is taken with the last iterate, and its residual says so.
pub const CG_MAX_ITERATIONS: u32 = 200;

// The preconditioner is a run's choice (`integrator::StepOptions`), kept beside the integrators
// and seen from here too.
pub use crate::integrator::{MULTIGRID_MIN_MASSES, MULTIGRID_MIN_STIFFNESS, Preconditioner};

/// How stiff `model`'s system is against a solve of `step`: the largest (h² Σk + h Σc) / m over
/// its free masses, Σ over each mass's springs, h the step the system is solved over (two
/// thirds of dt for BDF2). Gershgorin's bound on h² M⁻¹K + h M⁻¹D: near zero the system is its
/// masses', and block Jacobi's CG converges in a few iterations; large, corrections have to
/// cross the body, one spring an iteration, and multigrid carries them. Contacts are left out,
/// unlike `stability::Modes`' bound: each is a mass's own block, which block Jacobi inverts
/// whole.
pub fn stiffness_against_step(model: &crate::model::Model, step: crate::integrator::Step) -> f64 {
    // Step 1 of the run: BDF2's solve step from its second step on.
    let h = f64::from(BackwardStep::of(step.integrator, step.dt_secs as f32, 1).solve_secs);
    (0..model.mass_count())
        .filter(|&i| model.inv_mass[i] != 0.0)
        .map(|i| {
            let (k, c) = model.adjacency.of(i).iter().fold((0.0, 0.0), |(k, c), nb| {
                let s = &model.springs[nb.spring as usize];
                (
                    k + f64::from(s.stiffness_n_per_m),
                    c + f64::from(s.damping_n_s_per_m),
                )
            });
            (h * h * k + h * c) / f64::from(model.mass_kg[i])
        })
        .fold(0.0, f64::max)
}

/// The preconditioner a run of `model` as `step` takes for implicit Euler's and BDF2's CG: the
/// one it asks for, else the one its size and stiffness against the step call for. (An
/// integrator without a solve measures nothing: block Jacobi, unused.)
pub fn preconditioner_of(
    model: &crate::model::Model,
    step: crate::integrator::Step,
) -> Preconditioner {
    if !step.integrator.newton() {
        return step.options.preconditioner.unwrap_or_default();
    }
    step.options
        .preconditioner_for(model.mass_count(), stiffness_against_step(model, step))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::{Integrator, Step};
    use crate::model::ModelBuilder;
    use glam::Vec3;

    /// A chain pinned at one end, 2 kg then 1 kg, springs of 100 and 300 N/m with 2 and 4 N·s/m:
    /// the middle mass feels both springs ((h² 400 + h 6) / 2), the last one the second
    /// ((h² 300 + h 4) / 1), the pinned one none. BDF2 solves over two thirds of the step.
    #[test]
    fn stiffness_against_the_step_is_the_stiffest_free_row() {
        let mut mb = ModelBuilder::new();
        let pin = mb.mass(Vec3::ZERO, Vec3::ZERO, 1e-3, true);
        let a = mb.mass(Vec3::X, Vec3::ZERO, 2.0, false);
        let b = mb.mass(2.0 * Vec3::X, Vec3::ZERO, 1.0, false);
        mb.spring(pin, a, 100.0, 2.0);
        mb.spring(a, b, 300.0, 4.0);
        let model = mb.build();
        let row = |h: f64| ((h * h * 400.0 + h * 6.0) / 2.0).max(h * h * 300.0 + h * 4.0);
        for (integrator, h) in [
            (Integrator::Implicit, 0.1),
            (Integrator::Bdf2, 0.1 * 2.0 / 3.0),
        ] {
            let s = stiffness_against_step(&model, Step::new(integrator, 0.1));
            assert!(
                (s / row(h) - 1.0).abs() < 1e-6,
                "{integrator}: {s} against {}",
                row(h)
            );
        }
        // Three masses are below MULTIGRID_MIN_MASSES whatever the step.
        let stiff = Step::new(Integrator::Implicit, 10.0);
        assert_eq!(
            preconditioner_of(&model, stiff),
            Preconditioner::BlockJacobi
        );
        assert_eq!(
            Preconditioner::for_system(MULTIGRID_MIN_MASSES, MULTIGRID_MIN_STIFFNESS),
            Preconditioner::Multigrid
        );
        assert_eq!(
            Preconditioner::for_system(MULTIGRID_MIN_MASSES, 0.99 * MULTIGRID_MIN_STIFFNESS),
            Preconditioner::BlockJacobi
        );
    }
}
