//! Newton's stopping rules for implicit Euler and BDF2, in f32 as the shaders take them
//! (shaders/implicit_terms.wgsl's functions of the same names, whose constants the host sets
//! from `physics` as f32 overrides): the CPU's steps end, halve and go on exactly where
//! lavapipe's do. Each rule compares a sum of `solver_sums::group_reduce`.

use crate::physics::{
    NEWTON_BACKTRACKS, NEWTON_OVERSHOOT, NEWTON_STALL, NEWTON_TOLERANCE, newton_floor,
    newton_residual,
};

/// One step's Newton tolerance and floor, as the shaders' `NEWTON_RESIDUAL` and `NEWTON_FLOOR`
/// hold them (`physics::newton_residual` and `newton_floor` of the run's step, in f32), and the
/// model's weight (`physics::weight_norm_n`, the shaders' `WEIGHT_N`), which the caller keeps.
#[derive(Debug, Clone, Copy)]
pub struct NewtonRules {
    pub tolerance: f32,
    pub floor: f32,
    pub weight_n: f32,
}

impl NewtonRules {
    pub fn of(dt_secs: f64, order: u32, weight_n: f32) -> Self {
        NewtonRules {
            tolerance: newton_residual(dt_secs, order) as f32,
            floor: newton_floor(dt_secs, order) as f32,
            weight_n,
        }
    }
}

/// The momentum change an iterate's residual is judged against: |h f| at that iterate (at a
/// solution it is |M Δv|, the step's own), and at least `h` times the weight `weight_n`.
/// Not the first iterate's |h f|: at an impact the first iterate, x + h v, sinks deep into the
/// collider, and its contact forces made that scale hundreds of times the step's real momentum
/// change, so that an iterate far from any solution passed the rule (docs/stability.md).
pub fn newton_scale(hf: f32, h: f32, weight_n: f32) -> f32 {
    hf.max(h * weight_n)
}

/// Whether Newton's residual `residual` (|h f − M Δv| at the current iterate) is small enough
/// to end the step there: at most `tolerance` (`physics::newton_residual` of the step) of the
/// step's momentum change `scale`.
pub fn newton_done(residual: f32, scale: f32, tolerance: f32) -> bool {
    residual <= tolerance * scale
}

/// Whether Newton's residual `residual` has stalled at the floor of f32 forces: below `floor`
/// (`physics::newton_floor` of the step) of the step's momentum change `scale`, and not halved
/// since the last iterate's (`last`). The step then ends at the current iterate.
pub fn newton_stalled(residual: f32, last: f32, scale: f32, floor: f32) -> bool {
    residual <= floor * scale && residual > NEWTON_STALL as f32 * last
}

/// Whether the last update left Newton's residual `residual` above `physics::NEWTON_OVERSHOOT`
/// times the one it started from (`last`), with fewer than `physics::NEWTON_BACKTRACKS`
/// halvings of it so far: it is then halved (`implicit::newton_halve`) rather than solved from.
pub fn newton_overshot(residual: f32, last: f32, halvings: u32) -> bool {
    residual > NEWTON_OVERSHOOT as f32 * last && halvings < NEWTON_BACKTRACKS
}

/// Whether a step whose Newton iterations ran out wandered: the last iterate it evaluated
/// (residual `last`) was more than `physics::NEWTON_OVERSHOOT` times worse than the best it
/// solved from (`best`, `f32::MAX` while none), so that it ends at the best instead of its last
/// update. A step that ran out near its floor (a very stiff spring) ends at its last update.
pub fn newton_wandered(last: f32, best: f32) -> bool {
    best < f32::MAX && last > NEWTON_OVERSHOOT as f32 * best
}

/// Newton has converged when its update `step` (the largest |δ|) is small against Δv (the
/// largest |Δv|, `size`), or below 1e-7 m/s.
pub fn newton_converged(step: f32, size: f32) -> bool {
    step <= NEWTON_TOLERANCE as f32 * size || step < 1e-7
}

/// `residual` as a share of the step's momentum change `scale`, 0 where nothing moves
/// (the shaders' `relative`).
pub fn relative(residual: f32, scale: f32) -> f32 {
    if scale > 0.0 { residual / scale } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{NEWTON_FLOOR, NEWTON_RESIDUAL};

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
        let floor = NEWTON_FLOOR as f32;
        assert!(newton_stalled(2e-3, 3e-3, 1.0, floor));
        assert!(!newton_stalled(1e-4, 1.0, 1.0, floor));
        assert!(!newton_stalled(0.5, 0.6, 1.0, floor));
        assert!(!newton_stalled(1.0, f32::MAX, 1.0, floor));
        // At one step per frame the floor is three times the tolerance; at small steps, the
        // floor of f32 forces.
        assert!((newton_floor(1.0 / 60.0, 1) - 2.0 * NEWTON_RESIDUAL).abs() < 1e-12);
        assert_eq!(newton_floor(1e-4, 1), NEWTON_FLOOR);
        let rules = NewtonRules::of(1.0 / 60.0, 1, 0.0);
        assert!(newton_stalled(0.045, 0.046, 1.0, rules.floor));
        assert_eq!(rules.tolerance, NEWTON_RESIDUAL as f32);
        // An update that leaves the residual over 1.1 times larger is halved, twice at most.
        assert!(newton_overshot(1.2, 1.0, 0));
        assert!(!newton_overshot(1.05, 1.0, 0));
        assert!(!newton_overshot(1.2, 1.0, NEWTON_BACKTRACKS));
        assert!(!newton_overshot(1.0, f32::MAX, 0));
        assert!(newton_converged(1e-5, 1.0) && !newton_converged(1e-3, 1.0));
        // Out of iterations: at the best iterate only if the last was well above it.
        assert!(newton_wandered(3.33, 0.3755) && !newton_wandered(1.05, 1.0));
        assert!(!newton_wandered(3.0, f32::MAX));
        assert_eq!(relative(1.0, 0.0), 0.0);
        // An iterate is judged against its own |h f|, and at least its weight's impulse.
        assert_eq!(newton_scale(2.0, 0.1, 10.0), 2.0);
        assert_eq!(newton_scale(0.5, 0.1, 10.0), 1.0);
    }
}
