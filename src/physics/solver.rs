//! Implicit Euler's stopping rules and iteration caps: the CPU backend stops by them, and the GPU
//! backend compiles them into its shaders (`override` constants) and sizes its budgets by them, so
//! that both backends stop a solve alike.

/// Inexact Newton: each linear solve stops once its residual is this share of the Newton
/// residual it started from (it went to 1e-4 of the step's |h f|). Solving further buys little,
/// as the system is only the linearisation at the current iterate (BENCHMARKS.md, "Implicit
/// Euler and VBD at one step per frame").
pub const CG_FORCING: f64 = 0.1;
/// Newton stops when the update is this small relative to Δv (or Δv is below 1e-7 m/s).
pub const NEWTON_TOLERANCE: f64 = 1e-4;
/// Newton iteration cap per step.
pub const NEWTON_MAX_ITERATIONS: u32 = 10;
/// At one step per frame (`NEWTON_RESIDUAL_STEP_SECS`), Newton stops once its residual
/// |h f − M Δv| is at most this share of the step's momentum change |h f| (taken at the first
/// iterate): the step's equations hold to 3%. Measured on jello and cloth at 1/60 s over 1 s,
/// positions then differ from a solve to the f32 floor by 2.7e-2 and 2.1e-2 m RMS, against 1.2
/// and 0.09 m between implicit Euler at 1/60 s and semi-implicit Euler at the scenes' own steps
/// (2% and a quarter of the scheme's own error), at a third and a fifth of the cost.
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

/// Newton's residual tolerance at step `h_secs`, relative to |h f|: `NEWTON_RESIDUAL` at one
/// step per frame, and in proportion to the step below it. The scheme's own error per step
/// falls as h² and |h f| as h, so the solver's error stays a fixed share of the scheme's: with
/// 3% at every step, implicit Euler's error on hair stopped halving with the step between 8e-4
/// and 2e-4 s, and at 2e-4 s the hair gained energy.
pub fn newton_residual(h_secs: f64) -> f64 {
    NEWTON_RESIDUAL * (h_secs / NEWTON_RESIDUAL_STEP_SECS).min(1.0)
}
/// Iteration cap: a step that needs more is taken with the last iterate, and its residual says so.
pub const CG_MAX_ITERATIONS: u32 = 200;
