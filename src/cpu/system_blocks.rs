//! A mass's 3 × 3 diagonal block of backward Euler's system M − h D − h² K: each spring's and
//! contact's share of it, scaled by h, its own mass, and its inverse. Implicit Euler's
//! block-Jacobi preconditioner (`implicit.rs`) and VBD's block solve (`vbd.rs`) both build it.
//! Mirrors `shaders/system_blocks.wgsl`.

use glam::{Mat3, Vec3};

use super::law::Real;
use crate::model::{ContactModel, Effects, Pose, Spring};

/// One spring's share of the system, scaled by h: h²k along n, h²k·max(0, 1 − L/l) across it,
/// h c along it.
#[derive(Debug, Clone, Copy, Default)]
pub struct SpringTerms {
    pub n: Vec3,
    pub stiff_along: f32,
    pub stiff_across: f32,
    pub damp_along: f32,
}

/// One contact's share: h²k_c and h c_c along its normal.
#[derive(Debug, Clone, Copy)]
pub struct ContactTerms {
    pub n: Vec3,
    pub stiff: f32,
    pub damp: f32,
}

impl SpringTerms {
    /// Spring `s`'s share of the system at positions `xa`, `xb` of its ends, scaled by h (none
    /// for a spring too short to have a direction).
    #[inline(always)]
    pub fn at(s: &Spring, xa: Vec3, xb: Vec3, h: f32) -> Self {
        let d = xa - xb;
        let len = d.length();
        if len > <f32 as Real>::MIN_SPRING_LENGTH {
            let k = h * h * s.stiffness_n_per_m;
            SpringTerms {
                n: d * (1.0 / len),
                stiff_along: k,
                stiff_across: k * (1.0 - s.rest_m / len).max(0.0),
                damp_along: h * s.damping_n_s_per_m,
            }
        } else {
            SpringTerms::default()
        }
    }

    /// Its 3 × 3 block at either end: (h²k + h c) n nᵀ + h²k·max(0, 1 − L/l)(I − n nᵀ).
    #[inline(always)]
    pub fn block(&self) -> Mat3 {
        outer(self.n) * (self.stiff_along + self.damp_along - self.stiff_across)
            + Mat3::from_diagonal(Vec3::splat(self.stiff_across))
    }
}

impl ContactTerms {
    /// A penalty contact along `n` on a mass `m`: its spring and dashpot, scaled by h.
    #[inline(always)]
    pub fn at(n: Vec3, c: &ContactModel, m: f32, h: f32) -> Self {
        ContactTerms {
            n,
            stiff: h * h * c.stiffness_n_per_m,
            damp: h * 2.0 * c.damping_ratio * (c.stiffness_n_per_m * m).sqrt(),
        }
    }

    /// Its 3 × 3 block: (h²k_c + h c_c) n nᵀ.
    #[inline(always)]
    pub fn block(&self) -> Mat3 {
        outer(self.n) * (self.stiff + self.damp)
    }
}

/// The contacts mass `i` (of mass `m`) is in at `x`, each with its terms: the ground, then the
/// colliders in order.
pub fn contacts_at(
    effects: &Effects,
    poses: &[Pose],
    x: Vec3,
    m: f32,
    h: f32,
    mut each: impl FnMut(ContactTerms),
) {
    if let Some(g) = effects.ground.as_ref().filter(|g| g.height_m - x.y > 0.0) {
        each(ContactTerms::at(Vec3::Y, &g.contact, m, h));
    }
    for (c, pose) in effects.colliders.iter().zip(poses) {
        if let Some((_, n)) = c.shape.penetration(pose.position_m, x) {
            each(ContactTerms::at(n, &c.contact, m, h));
        }
    }
}

/// A mass's own block, m(1 + hγ) I (γ the air drag).
#[inline(always)]
pub fn own_block(m: f32, h: f32, drag: f32) -> Mat3 {
    Mat3::from_diagonal(Vec3::splat(m * (1.0 + h * drag)))
}

/// n nᵀ.
#[inline(always)]
pub fn outer(n: Vec3) -> Mat3 {
    Mat3::from_cols(n * n.x, n * n.y, n * n.z)
}

/// The inverse of a symmetric positive definite 3 × 3 block, by its adjugate (whose columns are
/// the cross products of the block's, as the WGSL twin computes it).
#[inline(always)]
pub fn invert_block(a: Mat3) -> Mat3 {
    let (c0, c1, c2) = (a.x_axis, a.y_axis, a.z_axis);
    let (r0, r1, r2) = (c1.cross(c2), c2.cross(c0), c0.cross(c1));
    let det = c0.dot(r0);
    // The block holds m(1 + hγ) I at least, so det ≥ m³ > 0; symmetric, so its adjugate is too.
    Mat3::from_cols(r0, r1, r2) * (1.0 / det)
}
