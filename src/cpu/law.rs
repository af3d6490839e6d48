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

/// The normal force of a Kelvin–Voigt contact (spring `k`, damper 2ζ√(km)) at signed depth
/// `depth` (negative outside) for a normal velocity `vn` (negative approaching): k·depth − c·vn
/// while that pushes, zero otherwise. The contact is on while its force pushes, not while the
/// mass is inside: a fast approach is damped just before the touch (within c|vn|/k of the
/// surface), so the force has no jump there, which left Newton's method in the implicit schemes
/// with no solution to find (docs/stability.md), and an impact keeps the linear oscillator's
/// restitution exactly (`laws::contact_law`). The shaders' `contact_normal_force`.
#[inline(always)]
pub fn contact_normal_force<F: Real>(c: &ContactModel, depth: F, vn: F, mass: F) -> F {
    let stiffness = F::of(c.stiffness_n_per_m);
    let damper = -F::of(2.0) * F::of(c.damping_ratio) * (stiffness * mass).sqrt() * vn;
    (stiffness * depth + damper).max(F::ZERO)
}

/// Whether a contact at signed depth `depth` acts at all: it pushes, or the mass is inside (a
/// mass leaving faster than its spring pushes feels nothing, but the energy its spring held
/// leaves the ledger through the damper's rate). The shaders' `contact_acts`.
#[inline(always)]
pub fn contact_acts<F: Real>(normal_force: F, depth: F) -> bool {
    normal_force > F::ZERO || depth > F::ZERO
}

/// Penalty contact along unit normal `n` at signed depth `depth` ([`contact_normal_force`]), for
/// a mass with velocity `v_rel` relative to the collider and `load`, every other force on it in
/// this evaluation (springs, gravity, drag, earlier contacts). Returns the force and the power
/// its damping and friction take out at the current velocity.
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
    let vn = F::dot(v_rel, n);
    let fn_total = contact_normal_force(c, depth, vn, mass);
    // The spring holds energy only inside; the rest of the force is the damper's.
    let spring = F::of(c.stiffness_n_per_m) * depth.max(F::ZERO);
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
