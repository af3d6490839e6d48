//! Vertex Block Descent (Chen et al. 2024): backward Euler's equations solved by a fixed number
//! of Gauss–Seidel sweeps over the masses, each mass a 3 × 3 Newton step; first order, for
//! large steps at a fixed cost (see src/cpu/vbd.rs).

use super::descriptor::{Amplification, Over, Scheme, Solve, StableStep, Sweeps};
use super::implicit::backward_euler_step;

pub const SCHEME: Scheme = Scheme {
    name: "vbd",
    title: "VBD",
    order: 1,
    solve: Solve::Sweeps(Sweeps {
        over: Over::Masses,
        flag: "--vbd-iterations",
        per: "step",
        instead: "implicit (Newton and conjugate gradients)",
        // Contacts and drag are in each mass's block.
        contacts_as: None,
    }),
    stable_step: StableStep::Any {
        why: "any on one spring (backward Euler's equations); on a body, the step at which its \
              sweeps still converge the springs (`stability::SweepReach`)",
    },
    // Its block solve of a lone linear oscillator is exact in one sweep.
    amplification: Amplification::Step(backward_euler_step),
};
