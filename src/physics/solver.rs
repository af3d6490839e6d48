//! Implicit Euler's stopping rules and iteration caps: the CPU backend stops by them, and the GPU
//! backend compiles them into its shaders (`override` constants) and sizes its budgets by them, so
//! that both backends stop a solve alike.

/// Relative residual |r| / |b| at which each linear solve stops (f32 vectors: near their floor
/// on stiff systems, whose condition number reaches k·dt²/m).
pub const CG_TOLERANCE: f64 = 1e-4;
/// Newton stops when the update is this small relative to Δv (or Δv is below 1e-7 m/s).
pub const NEWTON_TOLERANCE: f64 = 1e-4;
/// Newton iteration cap per step.
pub const NEWTON_MAX_ITERATIONS: u32 = 10;
/// Newton also stops once its residual |h f − M Δv| is below this share of the step's first
/// and the last update did not halve it (`NEWTON_STALL`): the residual has reached the floor of
/// f32 forces (a stiff spring's tension cancelling gravity leaves |b| about 3e-3 of the first on
/// the hair scene), where further updates are rounding noise. Without this rule such a step ran
/// all NEWTON_MAX_ITERATIONS iterations, each moving Δv by noise.
pub const NEWTON_FLOOR: f64 = 1e-2;
/// See `NEWTON_FLOOR`.
pub const NEWTON_STALL: f64 = 0.5;
/// Iteration cap: a step that needs more is taken with the last iterate, and its residual says so.
pub const CG_MAX_ITERATIONS: u32 = 200;
