//! Semi-implicit (symplectic) Euler: first order, bounded energy error.

use super::descriptor::{Amplification, Explicit, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "semi-implicit",
    title: "semi-implicit Euler",
    order: 1,
    solve: Solve::Explicit(Explicit::OneUpdate { symplectic: true }),
    stable_step: StableStep::Limited,
    amplification: Amplification::Step(step),
};

fn step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    let v1 = v + o.dt * o.acc(x, v);
    [x + o.dt * v1, v1, 0.0]
}
