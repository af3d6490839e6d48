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
/// relative to the collider. Returns the force and the power dissipated by its damping and
/// friction parts (≥ 0). Friction is Coulomb, `|F_t| ≤ μ F_n`, and stops at most `stick_share`
/// of the sliding within one step (1 for a collider: it cannot reverse the motion; less for
/// mass pairs, several of which may act on one mass, see `PAIR_STICK_SHARE`).
#[inline(always)]
pub fn contact_force<F: Real>(
    c: &ContactModel,
    depth: F,
    n: F::V,
    v_rel: F::V,
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
        let speed = F::length(vt);
        if speed > F::ZERO {
            let ft = (F::of(c.friction) * fn_total).min(stick_share * mass * speed / dt);
            force -= vt * (ft / speed);
            dissipated += ft * speed;
        }
    }
    (force, dissipated)
}
