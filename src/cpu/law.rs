//! The force laws, written once for both precisions (generic over [`Real`]): the backends
//! evaluate them in f32, the accuracy benchmark's reference solution in f64. Each is the same
//! sequence of operations in either precision, the f32 one matching the WGSL's.

pub use crate::real::Real;

use crate::model::{ContactModel, Spring};

/// Force exerted on mass `i` by spring `s` whose other end is `j`: elastic plus damping along the
/// spring, and the damping part's power at `i`. A zero-length spring has no direction and exerts
/// nothing (no division by zero).
#[inline(always)]
pub fn spring_force<F: Real>(s: &Spring, xi: F::V, xj: F::V, vi: F::V, vj: F::V) -> (F::V, F) {
    let d = xi - xj;
    let len = F::length(d);
    if len <= F::MIN_SPRING_LENGTH {
        return (F::V_ZERO, F::ZERO);
    }
    // One division, not three: the same on the GPU (forces.wgsl), so the two stay identical.
    let n = d * (F::ONE / len);
    let elastic = -F::of(s.stiffness_n_per_m) * (len - F::of(s.rest_m));
    let damping = -F::of(s.damping_n_s_per_m) * F::dot(vi - vj, n);
    (n * (elastic + damping), damping * F::dot(n, vi))
}

/// Penalty contact along unit normal `n` at depth `depth` > 0, for a mass with velocity `v_rel`
/// relative to the collider and `load`, every other force on it in this evaluation (springs,
/// gravity, drag, earlier contacts). Returns the force and the power its damping and friction
/// take out at the current velocity.
///
/// Friction is Coulomb, `|F_t| ≤ μ F_n`, against the tangential velocity the step would end with
/// under the load alone, `w = v_t + dt·load_t / m`: it stops that within one step when it can
/// (sticking holds against the load) and pushes `μ F_n` against it otherwise. Opposing only the
/// current `v_t`, a load below the friction limit would leave a resting mass creeping at
/// `load_t·dt / m`, an error of first order in dt that swamped every solver's own on scenes with
/// friction. At most `stick_share` of `w` is stopped in a step (1 for a collider; less for mass
/// pairs, several of which may act on one mass, see `PAIR_STICK_SHARE`).
#[inline(always)]
pub fn contact_force<F: Real>(
    c: &ContactModel,
    depth: F,
    n: F::V,
    (v_rel, load): (F::V, F::V),
    mass: F,
    dt: F,
    stick_share: F,
) -> (F::V, F) {
    let stiffness = F::of(c.stiffness_n_per_m);
    let vn = F::dot(v_rel, n);
    let spring = stiffness * depth;
    let damper = -F::of(2.0) * F::of(c.damping_ratio) * (stiffness * mass).sqrt() * vn;
    // Contact pushes, never pulls: the damper may at most cancel the spring.
    let fn_total = (spring + damper).max(F::ZERO);
    let damper_part = fn_total - spring;
    let mut force = n * fn_total;
    let mut dissipated = -damper_part * vn;
    if c.friction > 0.0 {
        let vt = v_rel - n * vn;
        let load_t = load - n * F::dot(load, n);
        let wt = vt + load_t * (dt / mass);
        let trial = F::length(wt);
        if trial > F::ZERO {
            let ft = (F::of(c.friction) * fn_total).min(stick_share * mass * trial / dt);
            let scale = ft / trial;
            force -= wt * scale;
            dissipated += scale * F::dot(wt, vt);
        }
    }
    (force, dissipated)
}
