//! The integrators as a table: the enum the command line and scene files name, and its row,
//! the [`Scheme`] each scheme's file in this folder describes. Adding a scheme is a variant, a
//! file and a row here; the compiler then names the backends' tables (the CPU's step in
//! `cpu/integrate.rs`; the GPU's passes in `gpu/plan.rs` and `gpu/fused_plan.rs`) and nothing
//! else (docs/ARCHITECTURE.md, "One room per integrator").

use serde::{Deserialize, Serialize};

use super::descriptor::Scheme;
use super::oscillator::Oscillator;
use super::{bdf2, euler, implicit, rk2, rk4, semi_implicit, vbd, verlet, xpbd};

/// Time integration scheme. Names match `--integrator` and the scene's `solver.integrator`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// Explicit (forward) Euler: first order, gains energy on undamped oscillation.
    Euler,
    /// Semi-implicit (symplectic) Euler: first order, bounded energy error.
    #[default]
    SemiImplicit,
    /// Runge–Kutta midpoint: second order.
    Rk2,
    /// Classic Runge–Kutta: fourth order.
    Rk4,
    /// Velocity Verlet: second order, symplectic for conservative forces.
    Verlet,
    /// Backward (implicit) Euler, solved by preconditioned conjugate gradients: first order,
    /// stable at any dt (it damps), for stiff scenes and large steps.
    Implicit,
    /// Extended position-based dynamics: springs as compliant constraints (α = 1/k), projected
    /// by graph-coloured Gauss–Seidel, in many substeps of one iteration each ("small steps"):
    /// first order, stable at any dt on a spring, softer than the springs when substeps are
    /// large (see src/cpu/xpbd.rs).
    Xpbd,
    /// Vertex Block Descent (Chen et al. 2024): backward Euler's equations solved by a fixed
    /// number of Gauss–Seidel sweeps over the masses, each mass a 3 × 3 Newton step; first order,
    /// for large steps at a fixed cost (see src/cpu/vbd.rs).
    Vbd,
    /// Second-order backward differentiation (BDF2): implicit Euler's Newton–CG solve, taken from
    /// a blend of the last two states over two thirds of the step (`physics::BackwardStep`);
    /// second order, stable at any dt, with far less numerical damping than implicit Euler at
    /// large steps. Its first step is an implicit Euler step.
    Bdf2,
}

impl Integrator {
    pub const ALL: [Integrator; 9] = [
        Integrator::Euler,
        Integrator::SemiImplicit,
        Integrator::Rk2,
        Integrator::Rk4,
        Integrator::Verlet,
        Integrator::Implicit,
        Integrator::Xpbd,
        Integrator::Vbd,
        Integrator::Bdf2,
    ];

    /// The explicit schemes, which both backends run.
    pub const EXPLICIT: [Integrator; 5] = [
        Integrator::Euler,
        Integrator::SemiImplicit,
        Integrator::Rk2,
        Integrator::Rk4,
        Integrator::Verlet,
    ];

    /// The explicit schemes with a stable step on an undamped spring, in the order messages
    /// suggest them (forward Euler and RK2 have none, and XPBD softens the springs).
    pub const STABLE_EXPLICIT: [Integrator; 3] = [
        Integrator::SemiImplicit,
        Integrator::Verlet,
        Integrator::Rk4,
    ];

    /// This integrator's row.
    pub fn scheme(self) -> &'static Scheme {
        match self {
            Integrator::Euler => &euler::SCHEME,
            Integrator::SemiImplicit => &semi_implicit::SCHEME,
            Integrator::Rk2 => &rk2::SCHEME,
            Integrator::Rk4 => &rk4::SCHEME,
            Integrator::Verlet => &verlet::SCHEME,
            Integrator::Implicit => &implicit::SCHEME,
            Integrator::Xpbd => &xpbd::SCHEME,
            Integrator::Vbd => &vbd::SCHEME,
            Integrator::Bdf2 => &bdf2::SCHEME,
        }
    }

    /// The name used on the command line and in scene files.
    pub fn name(self) -> &'static str {
        self.scheme().name
    }

    /// Global order of accuracy: halving dt divides the error by `2^order`.
    pub fn order(self) -> u32 {
        self.scheme().order
    }

    /// Whether every step is stable on a spring (implicit Euler, BDF2, VBD and XPBD): no stable
    /// step to estimate, and no substeps needed for stability.
    pub fn unconditionally_stable(self) -> bool {
        self.scheme().unconditionally_stable()
    }

    /// Whether a step solves backward Euler's equations by Newton's method and conjugate
    /// gradients (implicit Euler, and BDF2 from its blended start): the solver, its stopping
    /// rules and its statistics are theirs.
    pub fn newton(self) -> bool {
        self.scheme().newton()
    }

    /// Spectral radius of one step on the linear test oscillator `x'' = -ω² x - 2ζω x'`.
    pub fn amplification(self, omega: f64, zeta: f64, dt: f64) -> f64 {
        self.scheme().amplification(&Oscillator { omega, zeta, dt })
    }

    /// Largest dt for which the stiffest mode (angular frequency `omega`, damping ratio `zeta`)
    /// does not grow, found by bisection on the scheme's amplification. `None` when it grows
    /// even at ωdt = 0.01 (explicit Euler and RK2 on an undamped or barely damped mode).
    pub fn stable_dt(self, omega: f64, zeta: f64) -> Option<f64> {
        if omega <= 0.0 {
            return Some(f64::INFINITY);
        }
        if self.unconditionally_stable() {
            // A-stable: |R(z)| = 1/|1 − z| ≤ 1 on the whole left half-plane. One XPBD
            // projection of a spring is a backward-Euler step of it (the tests check both).
            return Some(f64::INFINITY);
        }
        let stable = |dt: f64| self.amplification(omega, zeta, dt) <= 1.0 + 1e-12;
        // Every scheme here is unstable by ωdt = 4; search below that. The probe at ωdt = 0.01
        // is where the weak growth of forward Euler and RK2 on an undamped mode (ρ − 1 of order
        // (ωdt)² and (ωdt)⁴) is still far above f64 round-off; a scheme unstable there is
        // reported as unstable at any practical dt.
        let probe = 1e-2 / omega;
        if !stable(probe) {
            return None;
        }
        let (mut lo, mut hi) = (probe, 4.0 / omega);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if stable(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(lo)
    }
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ALL` lists every variant once, in the order `--help` lists them (clap's derive knows
    /// every variant, so a new one fails here until it is listed).
    #[test]
    fn all_lists_every_integrator() {
        use clap::ValueEnum as _;
        assert_eq!(Integrator::value_variants(), &Integrator::ALL);
        for i in Integrator::ALL {
            assert_eq!(
                i.scheme().name,
                i.to_possible_value()
                    .map_or(String::new(), |v| v.get_name().to_owned())
            );
        }
    }

    /// A scheme of sweeps that steps its contacts as another scheme names one that exists, with
    /// a stable step of its own to hold it.
    #[test]
    fn contacts_are_stepped_as_a_scheme_with_a_limit() {
        for i in Integrator::ALL {
            let Some(name) = i.scheme().sweeps().and_then(|s| s.contacts_as) else {
                continue;
            };
            let other = Integrator::ALL.into_iter().find(|o| o.name() == name);
            assert!(
                other.is_some_and(|o| !o.unconditionally_stable()),
                "{i}: contacts as '{name}'"
            );
        }
    }

    #[test]
    fn stability_limits_match_theory_for_undamped_oscillator() {
        let w = 10.0;
        assert!(Integrator::Euler.stable_dt(w, 0.0).is_none());
        assert!(Integrator::Rk2.stable_dt(w, 0.0).is_none());
        let se = Integrator::SemiImplicit.stable_dt(w, 0.0).unwrap_or(0.0);
        assert!(
            (se * w - 2.0).abs() < 1e-6,
            "semi-implicit ωdt = {}",
            se * w
        );
        let vv = Integrator::Verlet.stable_dt(w, 0.0).unwrap_or(0.0);
        assert!((vv * w - 2.0).abs() < 1e-6, "verlet ωdt = {}", vv * w);
        assert_eq!(Integrator::Implicit.stable_dt(w, 0.0), Some(f64::INFINITY));
        assert!(
            Integrator::Implicit.amplification(w, 0.0, 100.0) < 1.0,
            "backward Euler must damp at any dt"
        );
        for dt in [1e-3, 0.1, 1.0, 100.0] {
            let r = Integrator::Xpbd.amplification(w, 0.0, dt);
            assert!(r <= 1.0 + 1e-12, "xpbd grows by {r} at ωdt = {}", w * dt);
        }
        let rk4 = Integrator::Rk4.stable_dt(w, 0.0).unwrap_or(0.0);
        assert!(
            (rk4 * w - 8f64.sqrt()).abs() < 1e-6,
            "rk4 ωdt = {}",
            rk4 * w
        );
    }

    #[test]
    fn overdamped_semi_implicit_euler_is_held_by_its_damping() {
        // ωh ≤ 2(√(ζ²+1) − ζ): with ζ = 2.318, half the undamped limit and less.
        let (w, zeta) = (4.5242e4, 2.318);
        let dt = Integrator::SemiImplicit.stable_dt(w, zeta).unwrap_or(0.0);
        let theory = 2.0 * ((zeta * zeta + 1.0).sqrt() - zeta) / w;
        assert!((dt / theory - 1.0).abs() < 1e-9, "{dt} against {theory}");
    }

    #[test]
    fn verlet_with_its_kept_acceleration_loses_step_to_damping() {
        // Undamped, the kept acceleration is exact: ωh ≤ 2 as for textbook Verlet. Damped, it
        // was taken at the predicted velocity, and the limit falls below the textbook scheme's
        // (which damping would raise): hair's measured 1.341e-3 s against 1.371e-3 s.
        let w = 1417.0;
        let undamped = Integrator::Verlet.stable_dt(w, 0.0).unwrap_or(0.0);
        assert!((undamped * w - 2.0).abs() < 1e-6, "ωdt = {}", undamped * w);
        let damped = Integrator::Verlet.stable_dt(w, 0.031).unwrap_or(0.0);
        assert!(
            damped * w < 0.95 * 2.0,
            "damping should cost Verlet's kept acceleration step: ωdt = {}",
            damped * w
        );
    }

    /// BDF2 is A-stable: no growth at any step on any damped or undamped mode, and L-stable:
    /// a stiff mode far beyond the step is damped away. On a slow mode it damps as little as
    /// its order says: ρ = 1 − O((ωh)⁴) undamped, where implicit Euler's loses O((ωh)²).
    #[test]
    fn bdf2_is_stable_at_any_step_and_damps_slow_modes_at_fourth_order() {
        for zeta in [0.0, 0.01, 0.5, 1.0, 3.0] {
            for wdt in [1e-3, 0.1, 1.0, 10.0, 1e4] {
                let r = Integrator::Bdf2.amplification(1.0, zeta, wdt);
                assert!(r <= 1.0 + 1e-12, "ρ = {r} at ζ = {zeta}, ωdt = {wdt}");
            }
        }
        assert!(Integrator::Bdf2.amplification(1.0, 0.0, 1e4) < 1e-2);
        let loss = |i: Integrator, wdt: f64| 1.0 - i.amplification(1.0, 0.0, wdt);
        let ratio = loss(Integrator::Bdf2, 0.1) / loss(Integrator::Bdf2, 0.05);
        assert!((ratio - 16.0).abs() < 0.5, "BDF2's loss fell by {ratio}");
        let ratio = loss(Integrator::Implicit, 0.1) / loss(Integrator::Implicit, 0.05);
        assert!(
            (ratio - 4.0).abs() < 0.1,
            "implicit Euler's loss fell by {ratio}"
        );
        assert_eq!(Integrator::Bdf2.stable_dt(1e3, 0.0), Some(f64::INFINITY));
    }

    #[test]
    fn damping_makes_euler_conditionally_stable() {
        // Forward Euler on a damped oscillator: stable while ωdt < 2ζ (for small ζ).
        let dt = Integrator::Euler.stable_dt(10.0, 0.05).unwrap_or(0.0);
        assert!((dt * 10.0 - 0.1).abs() < 2e-3, "ωdt = {}", dt * 10.0);
    }
}
