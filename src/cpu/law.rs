//! The force laws, written once for both precisions: the backends evaluate them in f32
//! (`f32`, `Vec3`), the accuracy benchmark's reference solution in f64 (`f64`, `DVec3`). Each
//! is the same sequence of operations in either precision, the f32 one matching the WGSL's.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

use glam::{DVec3, Vec3};

use crate::model::{ContactModel, Spring};

/// A float type and its 3-vector.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    type V: Copy
        + PartialEq
        + Add<Output = Self::V>
        + Sub<Output = Self::V>
        + Mul<Self, Output = Self::V>
        + AddAssign
        + SubAssign;
    const ZERO: Self;
    const ONE: Self;
    const V_ZERO: Self::V;
    /// Springs shorter than this have no direction and exert nothing.
    const MIN_SPRING_LENGTH: Self;
    fn of(x: f32) -> Self;
    fn sqrt(self) -> Self;
    fn max(self, other: Self) -> Self;
    fn min(self, other: Self) -> Self;
    fn dot(a: Self::V, b: Self::V) -> Self;
    fn length(v: Self::V) -> Self;
}

/// The backends' precision. `MIN_SPRING_LENGTH` is `MIN_SPRING_LENGTH` in shaders/common.wgsl.
impl Real for f32 {
    type V = Vec3;
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const V_ZERO: Vec3 = Vec3::ZERO;
    const MIN_SPRING_LENGTH: Self = f32::MIN_POSITIVE * 1e6;
    #[inline(always)]
    fn of(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f32::max(self, other)
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        f32::min(self, other)
    }
    #[inline(always)]
    fn dot(a: Vec3, b: Vec3) -> Self {
        a.dot(b)
    }
    #[inline(always)]
    fn length(v: Vec3) -> Self {
        v.length()
    }
}

/// The reference solution's precision.
impl Real for f64 {
    type V = DVec3;
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const V_ZERO: DVec3 = DVec3::ZERO;
    const MIN_SPRING_LENGTH: Self = f32::MIN_POSITIVE as f64 * 1e6;
    #[inline(always)]
    fn of(x: f32) -> Self {
        f64::from(x)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        f64::min(self, other)
    }
    #[inline(always)]
    fn dot(a: DVec3, b: DVec3) -> Self {
        a.dot(b)
    }
    #[inline(always)]
    fn length(v: DVec3) -> Self {
        v.length()
    }
}

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
