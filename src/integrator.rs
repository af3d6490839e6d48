//! The integrators, what they cost, and how large a step each survives.

use serde::{Deserialize, Serialize};

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

/// From this many masses on, where the system is also stiff against the step
/// (`MULTIGRID_MIN_STIFFNESS`), both backends precondition implicit Euler's conjugate gradients
/// by aggregation multigrid (`cpu/multigrid.rs`, `gpu/multigrid.rs`) unless the run names a
/// preconditioner. Below it the cycle saves no time on the CPU: on the eleven scenes of 100 to
/// 1 444 masses at 1/60 s, two cores, it took 3–6× fewer CG iterations and ran 0.75–1.49×
/// block Jacobi's speed (BENCHMARKS.md, "Multigrid in the one-workgroup step, and a
/// preconditioner to choose"). Whether it pays in the GPU's one-workgroup step is for a GPU to
/// measure (`bench/device/gpu_rows.sh mg`).
pub const MULTIGRID_MIN_MASSES: usize = 4096;

/// The system's stiffness against the step (`physics::stiffness_against_step`: the largest
/// (h² Σk + h Σc) / m over the masses) from which multigrid pays. Below it block Jacobi's CG
/// takes few iterations, each a fraction of a cycle's cost. On two cores (BENCHMARKS.md, "The
/// CPU's loops on the pool, and the preconditioner by stiffness against the step") the
/// crossing lay between 1 140 and 4 470 on cloth-256 (block Jacobi 1.9× multigrid's speed at
/// 0.6, 1.5× at 280, 1.2× at 1 140; multigrid 1.15× at 4 470, 4× at 17 900) and between 55 and
/// 210 on the 64 × 64 peer cloth (multigrid 1.3× at 210, 1.5× at 840; block Jacobi 1.9× at 55):
/// no one figure serves both, and 300 loses at most 1.3× on either.
pub const MULTIGRID_MIN_STIFFNESS: f64 = 300.0;

/// What preconditions implicit Euler's and BDF2's conjugate gradients. Names match
/// `--preconditioner` and the scene's `solver.preconditioner`; without either, both backends
/// take [`Preconditioner::for_system`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Preconditioner {
    /// Each mass's 3 × 3 diagonal block of the system, inverted (both backends).
    #[default]
    BlockJacobi,
    /// A V-cycle of aggregation multigrid over coarser copies of the system
    /// (`physics::hierarchy`): the CPU's `cpu/multigrid.rs`, the GPU's `gpu/multigrid.rs`.
    Multigrid,
}

impl Preconditioner {
    /// Both backends' choice for a system of `mass_count` masses, `stiffness` stiff against
    /// its step (`physics::stiffness_against_step`), when the run names none.
    pub fn for_system(mass_count: usize, stiffness: f64) -> Self {
        if mass_count >= MULTIGRID_MIN_MASSES && stiffness >= MULTIGRID_MIN_STIFFNESS {
            Preconditioner::Multigrid
        } else {
            Preconditioner::BlockJacobi
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Preconditioner::BlockJacobi => "3×3 block Jacobi",
            Preconditioner::Multigrid => "aggregation multigrid",
        }
    }
}

/// What an integrator needs beyond its name and step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOptions {
    /// XPBD's constraint iterations per substep (≥ 1; the others ignore it).
    pub xpbd_iterations: u32,
    /// VBD's sweeps over the masses per step (≥ 1; the others ignore it).
    pub vbd_iterations: u32,
    /// What preconditions implicit Euler's and BDF2's CG on both backends; `None`: each system
    /// as its size and stiffness say (`Preconditioner::for_system`).
    pub preconditioner: Option<Preconditioner>,
}

impl Default for StepOptions {
    fn default() -> Self {
        Self {
            xpbd_iterations: DEFAULT_XPBD_ITERATIONS,
            vbd_iterations: DEFAULT_VBD_ITERATIONS,
            preconditioner: None,
        }
    }
}

impl StepOptions {
    /// The preconditioner of a system of `mass_count` masses, `stiffness` stiff against its
    /// step: the one asked for, else the system's (`Preconditioner::for_system`). (One without
    /// coarse levels takes block Jacobi whatever is asked: `hooke check` says so.) A model's
    /// run asks `physics::preconditioner_of`, which measures the stiffness.
    pub fn preconditioner_for(&self, mass_count: usize, stiffness: f64) -> Preconditioner {
        self.preconditioner
            .unwrap_or_else(|| Preconditioner::for_system(mass_count, stiffness))
    }
}

/// "Small Steps": one iteration per substep, and more substeps where accuracy is wanted.
pub const DEFAULT_XPBD_ITERATIONS: u32 = 1;

/// VBD's sweeps per step: NVIDIA Newton's cloth examples run 10.
pub const DEFAULT_VBD_ITERATIONS: u32 = 10;

/// How a backend steps: the integrator, its step and its options. Both backends take one; a
/// run's comes from its [`Settings`](crate::scene::settings::Settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    pub integrator: Integrator,
    pub dt_secs: f64,
    pub options: StepOptions,
}

impl Step {
    /// `integrator` at `dt_secs`, with the default options.
    pub fn new(integrator: Integrator, dt_secs: f64) -> Self {
        Self {
            integrator,
            dt_secs,
            options: StepOptions::default(),
        }
    }

    pub fn with_options(self, options: StepOptions) -> Self {
        Self { options, ..self }
    }
}

/// An effect that some integrator cannot simulate, as [`Integrator::supports`] says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Unsupported {
    /// Mass–mass contact has no Jacobian in implicit Euler's system (a pair couples two masses
    /// along a normal that changes as they move): entering through the force only, stiff
    /// contacts would stall Newton, and VBD, which solves the same system, likewise.
    #[error("{} does not support {}", self.integrator_title(), self.effect())]
    MassContact(Integrator),
}

impl Unsupported {
    /// The effect, as a message names it.
    pub fn effect(self) -> &'static str {
        match self {
            Unsupported::MassContact(_) => "mass–mass contact",
        }
    }

    /// The integrator that refuses it, as a sentence names it.
    fn integrator_title(self) -> &'static str {
        match self {
            Unsupported::MassContact(Integrator::Vbd) => "VBD",
            Unsupported::MassContact(Integrator::Bdf2) => "BDF2",
            Unsupported::MassContact(_) => "implicit Euler",
        }
    }

    /// The scene file's table that asks for the effect.
    pub fn scene_field(self) -> &'static str {
        match self {
            Unsupported::MassContact(_) => "effects.self_collision",
        }
    }

    /// The integrators that do support it, by name: `semi-implicit, verlet or rk4`, each name
    /// between `quote`s.
    pub fn instead(self, quote: &str) -> String {
        let suggested: &[Integrator] = match self {
            // Forward Euler and RK2 have no step stable for sure, and XPBD softens the springs.
            Unsupported::MassContact(_) => &[
                Integrator::SemiImplicit,
                Integrator::Verlet,
                Integrator::Rk4,
            ],
        };
        let names: Vec<String> = suggested
            .iter()
            .filter(|i| i.supports(&self).is_ok())
            .map(|i| format!("{quote}{}{quote}", i.name()))
            .collect();
        match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }
}

/// An effect refused stands for a scene that asks for just that effect.
impl AskedEffects for Unsupported {
    fn mass_contact(&self) -> bool {
        matches!(self, Unsupported::MassContact(_))
    }
}

/// The effects a scene asks for, as far as an integrator may refuse them: the scene file's
/// `[effects]` (checked as it loads) and a built model's `Effects` (checked by the backends and
/// the accuracy bench) both answer, so the rule is written once, in [`Integrator::supports`].
pub trait AskedEffects {
    fn mass_contact(&self) -> bool;
}

impl Integrator {
    /// Whether this integrator can simulate every effect in `effects`; the one it cannot, if any.
    pub fn supports(self, effects: &impl AskedEffects) -> Result<(), Unsupported> {
        if (self.newton() || self == Integrator::Vbd) && effects.mass_contact() {
            return Err(Unsupported::MassContact(self));
        }
        Ok(())
    }
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

    /// Whether every step is stable on a spring (implicit Euler, BDF2, VBD and XPBD): no stable
    /// step to estimate, and no substeps needed for stability.
    pub fn unconditionally_stable(self) -> bool {
        matches!(
            self,
            Integrator::Implicit | Integrator::Bdf2 | Integrator::Xpbd | Integrator::Vbd
        )
    }

    /// Whether a step solves backward Euler's equations by Newton's method and conjugate
    /// gradients (implicit Euler, and BDF2 from its blended start): the solver, its stopping
    /// rules and its statistics are theirs.
    pub fn newton(self) -> bool {
        matches!(self, Integrator::Implicit | Integrator::Bdf2)
    }

    /// The name used on the command line and in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "euler",
            Integrator::SemiImplicit => "semi-implicit",
            Integrator::Rk2 => "rk2",
            Integrator::Rk4 => "rk4",
            Integrator::Verlet => "verlet",
            Integrator::Implicit => "implicit",
            Integrator::Xpbd => "xpbd",
            Integrator::Vbd => "vbd",
            Integrator::Bdf2 => "bdf2",
        }
    }

    /// Global order of accuracy: halving dt divides the error by `2^order`.
    pub fn order(self) -> u32 {
        match self {
            Integrator::Euler
            | Integrator::SemiImplicit
            | Integrator::Implicit
            | Integrator::Xpbd
            | Integrator::Vbd => 1,
            Integrator::Rk2 | Integrator::Verlet | Integrator::Bdf2 => 2,
            Integrator::Rk4 => 4,
        }
    }

    /// One step of this scheme on the linear test oscillator `x'' = -ω² x - 2ζω x'`, written
    /// exactly as the backends apply the scheme, so that its amplification is the scheme's own.
    /// The state is (x, v, a): `a` is what velocity Verlet keeps from the step before, the
    /// acceleration at the new position and the *predicted* velocity (both backends evaluate
    /// the force once a step and reuse it); the other schemes ignore it and return 0 there.
    /// BDF2, a two-step scheme, has no such map: `None` (`amplification` takes its roots).
    fn step_oscillator(
        self,
        omega: f64,
        zeta: f64,
        dt: f64,
        [x, v, a]: [f64; 3],
    ) -> Option<[f64; 3]> {
        let acc = |x: f64, v: f64| -omega * omega * x - 2.0 * zeta * omega * v;
        Some(match self {
            Integrator::Euler => [x + dt * v, v + dt * acc(x, v), 0.0],
            Integrator::SemiImplicit => {
                let v1 = v + dt * acc(x, v);
                [x + dt * v1, v1, 0.0]
            }
            Integrator::Rk2 => {
                let (xm, vm) = (x + 0.5 * dt * v, v + 0.5 * dt * acc(x, v));
                [x + dt * vm, v + dt * acc(xm, vm), 0.0]
            }
            Integrator::Rk4 => {
                let (k1x, k1v) = (v, acc(x, v));
                let (k2x, k2v) = (
                    v + 0.5 * dt * k1v,
                    acc(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v),
                );
                let (k3x, k3v) = (
                    v + 0.5 * dt * k2v,
                    acc(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v),
                );
                let (k4x, k4v) = (v + dt * k3v, acc(x + dt * k3x, v + dt * k3v));
                [
                    x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
                    v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
                    0.0,
                ]
            }
            // VBD's block solve of a lone linear oscillator is exact in one sweep.
            Integrator::Implicit | Integrator::Vbd => {
                // v₁ = v₀ + h a(x₀ + h v₁, v₁), solved exactly for the linear oscillator.
                let v1 = (v - dt * omega * omega * x)
                    / (1.0 + 2.0 * zeta * omega * dt + omega * omega * dt * dt);
                [x + dt * v1, v1, 0.0]
            }
            Integrator::Xpbd => {
                // Unit mass on a spring k = ω² with dashpot c = 2ζω: predict dx = h v, then one
                // projection (src/cpu/xpbd.rs) with α̃ = 1 / (k h²) and γ = c / (k h).
                let alpha = 1.0 / (omega * omega * dt * dt);
                let gamma = 2.0 * zeta / (omega * dt);
                let dx = dt * v;
                let dl = (-(x + dx) - gamma * dx) / (1.0 + gamma + alpha);
                [x + dx + dl, (dx + dl) / dt, 0.0]
            }
            Integrator::Verlet => {
                // src/cpu/integrate.rs: verlet_drift, the force at (x₁, v + h a), verlet_kick.
                let kicked = v + 0.5 * dt * a;
                let x1 = x + dt * kicked;
                let a1 = acc(x1, v + dt * a);
                [x1, kicked + 0.5 * dt * a1, a1]
            }
            Integrator::Bdf2 => return None,
        })
    }

    /// Spectral radius of one step on the test oscillator: the largest root of the
    /// characteristic polynomial of the step's 3 × 3 matrix.
    pub fn amplification(self, omega: f64, zeta: f64, dt: f64) -> f64 {
        let column = |k: usize| {
            let mut unit = [0.0; 3];
            unit[k] = 1.0;
            self.step_oscillator(omega, zeta, dt, unit)
        };
        let (Some(c0), Some(c1), Some(c2)) = (column(0), column(1), column(2)) else {
            return bdf2_amplification(omega, zeta, dt);
        };
        let m = |r: usize, c: usize| [c0, c1, c2][c][r];
        // det(zI − M) = z³ − t z² + s z − d.
        let t = m(0, 0) + m(1, 1) + m(2, 2);
        let s = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0) + m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0)
            + m(1, 1) * m(2, 2)
            - m(1, 2) * m(2, 1);
        let d = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1))
            - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
            + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
        cubic_spectral_radius(-t, s, -d)
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

/// BDF2's spectral radius on the test oscillator: on each mode y' = λ y it steps by the roots
/// of (3/2 − hλ) ρ² − 2ρ + 1/2 = 0, ρ = (2 ± √(1 + 2hλ)) / (3 − 2hλ). The oscillator's two
/// eigenvalues λ = ω(−ζ ± √(ζ² − 1)) are conjugate when underdamped, and so are their roots.
fn bdf2_amplification(omega: f64, zeta: f64, dt: f64) -> f64 {
    let disc = zeta * zeta - 1.0;
    let lambdas = if disc >= 0.0 {
        let s = disc.sqrt();
        [(omega * (-zeta + s), 0.0), (omega * (-zeta - s), 0.0)]
    } else {
        let s = (-disc).sqrt();
        [(-omega * zeta, omega * s), (-omega * zeta, -omega * s)]
    };
    let mut radius = 0.0f64;
    for (re, im) in lambdas {
        let (zr, zi) = (dt * re, dt * im);
        let root = complex_sqrt(1.0 + 2.0 * zr, 2.0 * zi);
        let denominator = (3.0 - 2.0 * zr, -2.0 * zi);
        let d2 = denominator.0 * denominator.0 + denominator.1 * denominator.1;
        for sign in [1.0, -1.0] {
            let (nr, ni) = (2.0 + sign * root.0, sign * root.1);
            radius = radius.max(((nr * nr + ni * ni) / d2).sqrt());
        }
    }
    radius
}

/// The principal square root of re + i·im.
fn complex_sqrt(re: f64, im: f64) -> (f64, f64) {
    let modulus = re.hypot(im);
    let r = (0.5 * (modulus + re)).max(0.0).sqrt();
    let i = (0.5 * (modulus - re)).max(0.0).sqrt();
    (r, if im < 0.0 { -i } else { i })
}

/// The largest modulus of the roots of z³ + a z² + b z + c: one real root by bisection (a
/// cubic always has one), then the quadratic left after dividing it out.
fn cubic_spectral_radius(a: f64, b: f64, c: f64) -> f64 {
    let p = |z: f64| ((z + a) * z + b) * z + c;
    // Cauchy's bound holds every root.
    let bound = 1.0 + a.abs().max(b.abs()).max(c.abs());
    let (mut lo, mut hi) = (-bound, bound);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if p(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = 0.5 * (lo + hi);
    // z³ + a z² + b z + c = (z − r)(z² + q1 z + q0).
    let (q1, q0) = (a + r, b + r * (a + r));
    let disc = q1 * q1 / 4.0 - q0;
    let quadratic = if disc >= 0.0 {
        let sq = disc.sqrt();
        (-q1 / 2.0 + sq).abs().max((-q1 / 2.0 - sq).abs())
    } else {
        q0.abs().sqrt()
    };
    r.abs().max(quadratic)
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
