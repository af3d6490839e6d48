//! Extended position-based dynamics: springs as compliant constraints (α = 1/k), projected by
//! graph-coloured Gauss–Seidel, in many substeps of one iteration each ("small steps"): first
//! order, stable at any dt on a spring, softer than the springs when substeps are large (see
//! src/cpu/xpbd.rs).

use super::descriptor::{Amplification, Over, Scheme, Solve, StableStep, Sweeps};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "xpbd",
    title: "XPBD",
    order: 1,
    solve: Solve::Sweeps(Sweeps {
        over: Over::Springs,
        flag: "--xpbd-iterations",
        per: "substep",
        instead: "implicit",
        // Predicted from the forces, then projected: semi-implicit Euler's step of them.
        contacts_as: Some(super::semi_implicit::SCHEME.name),
    }),
    stable_step: StableStep::Any {
        why: "any on one spring (a projection is a backward-Euler step of it); on a body, the \
              step at which its sweeps still converge the springs (`stability::SweepReach`), \
              and that of its contacts",
    },
    amplification: Amplification::Step(step),
};

/// Unit mass on a spring k = ω² with dashpot c = 2ζω: predict dx = h v, then one projection
/// (src/cpu/xpbd.rs) with α̃ = 1 / (k h²) and γ = c / (k h).
fn step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    let dt = o.dt;
    let alpha = 1.0 / (o.omega * o.omega * dt * dt);
    let gamma = 2.0 * o.zeta / (o.omega * dt);
    let dx = dt * v;
    let dl = (-(x + dx) - gamma * dx) / (1.0 + gamma + alpha);
    [x + dx + dl, (dx + dl) / dt, 0.0]
}
