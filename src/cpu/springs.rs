//! `update_springs`: plasticity and tearing, once after every step. Mirrors `update_springs` in
//! `shaders/springs.wgsl`.

use glam::Vec3;

use super::forces::Gather;
use crate::model::{Spring, SpringLimits};

/// Spring `s` after one step ends with its ends at `xa`, `xb`: broken past `break_strain`, or
/// with its rest length moved `relax` of the way toward the length at which its strain would be
/// exactly ±`yield_strain`. Returns the new spring and the elastic energy let go (≥ 0), or `None`
/// when nothing changes.
#[inline]
pub fn spring_update(s: &Spring, l: &SpringLimits, xa: Vec3, xb: Vec3) -> Option<(Spring, f32)> {
    if s.is_broken() {
        return None;
    }
    let len = xa.distance(xb);
    let stretch = len - s.rest_m;
    let strain = stretch / s.rest_m;
    if strain > l.break_strain {
        let broken = Spring {
            stiffness_n_per_m: 0.0,
            damping_n_s_per_m: 0.0,
            ..*s
        };
        return Some((broken, 0.5 * s.stiffness_n_per_m * stretch * stretch));
    }
    if strain.abs() > l.yield_strain {
        let target = len / (1.0 + strain.signum() * l.yield_strain);
        let rest_m = s.rest_m + l.relax * (target - s.rest_m);
        let left = len - rest_m;
        let released = 0.5 * s.stiffness_n_per_m * (stretch * stretch - left * left);
        return Some((Spring { rest_m, ..*s }, released));
    }
    None
}

/// Apply [`spring_update`] to every spring; returns the energy let go, summed in f64 in spring
/// order.
pub fn update_springs(limits: &[SpringLimits], gather: &mut Gather, x: &[Vec3]) -> f64 {
    let mut released = 0.0f64;
    for (k, l) in limits.iter().enumerate() {
        let s = gather.springs()[k];
        if let Some((new, e)) = spring_update(&s, l, x[s.a as usize], x[s.b as usize]) {
            gather.set_spring(k, new);
            released += f64::from(e);
        }
    }
    released
}
