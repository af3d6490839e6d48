//! A mass's 3 × 3 diagonal block of backward Euler's system M − h D − h² K: each spring's and
//! contact's share of it, scaled by h, its own mass, and its inverse. Implicit Euler's
//! block-Jacobi preconditioner (`implicit.rs`) and VBD's block solve (`vbd.rs`) both build it.
//! Mirrors `shaders/system_blocks.wgsl`.

use glam::{Mat3, Vec3};

use super::law::{Real, contact_normal_force};
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

    /// `out` plus its share of the product (M − h D − h² K) p at either end, for dp = p_i − p_j,
    /// its two parts added in turn (the WGSL's `add_entry_times`; n's sign cancels). Lavapipe's
    /// compiler adds `out + (a + b)` as `(out + a) + b`: written so, the backends agree.
    #[inline(always)]
    pub fn add_times(&self, out: Vec3, dp: Vec3) -> Vec3 {
        let dn = self.n.dot(dp);
        out + (self.stiff_along + self.damp_along) * dn * self.n
            + self.stiff_across * (dp - dn * self.n)
    }

    /// `block` plus its 3 × 3 block, its two parts added in turn (the WGSL's `add_spring_block`).
    #[inline(always)]
    pub fn add_block(&self, block: Mat3) -> Mat3 {
        block
            + outer(self.n) * (self.stiff_along + self.damp_along - self.stiff_across)
            + Mat3::from_diagonal(Vec3::splat(self.stiff_across))
    }

    /// Its 3 × 3 block at either end: (h²k + h c) n nᵀ + h²k·max(0, 1 − L/l)(I − n nᵀ).
    #[inline(always)]
    pub fn block(&self) -> Mat3 {
        outer(self.n) * (self.stiff_along + self.damp_along - self.stiff_across)
            + Mat3::from_diagonal(Vec3::splat(self.stiff_across))
    }
}

/// The sum of a mass's contacts' shares, Σ (h²k_c + h c_c) n nᵀ, kept as its diagonal (xx, yy,
/// zz) and off-diagonal (xy, xz, yz) entries, each added as `mass_force_beyond_springs`
/// (shaders/mass_force.wgsl) adds it, so that implicit Euler's blocks and products are the GPU's
/// to the bit.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactBlock {
    pub diag: Vec3,
    pub off: Vec3,
}

impl ContactBlock {
    /// The contacts that push mass `i` (of mass `m`) at `x` moving at `v`
    /// (`law::contact_normal_force`): the ground, then the colliders in order. A contact that
    /// does not push has no derivative (its force is zero about the iterate).
    #[inline(always)]
    pub fn at(effects: &Effects, poses: &[Pose], (x, v): (Vec3, Vec3), m: f32, h: f32) -> Self {
        let share = |c: &ContactModel| {
            let k = c.stiffness_n_per_m;
            h * h * k + h * 2.0 * c.damping_ratio * (k * m).sqrt()
        };
        let mut block = ContactBlock::default();
        if let Some(g) = effects.ground.as_ref()
            && contact_normal_force(&g.contact, g.height_m - x.y, v.y, m) > 0.0
        {
            block.diag.y += share(&g.contact);
        }
        for (c, pose) in effects.colliders.iter().zip(poses) {
            if let Some((depth, n)) = c.shape.signed_depth(pose.position_m, x) {
                let vn = (v - pose.velocity_m_per_s).dot(n);
                if contact_normal_force(&c.contact, depth, vn, m) > 0.0 {
                    let s = share(&c.contact);
                    block.diag += s * n * n;
                    block.off += s * Vec3::new(n.x * n.y, n.x * n.z, n.y * n.z);
                }
            }
        }
        block
    }

    /// As a 3 × 3 block (the WGSL's `symmetric_block`).
    #[inline(always)]
    pub fn block(&self) -> Mat3 {
        let (d, o) = (self.diag, self.off);
        Mat3::from_cols(
            Vec3::new(d.x, o.x, o.y),
            Vec3::new(o.x, d.y, o.z),
            Vec3::new(o.y, o.z, d.z),
        )
    }

    /// The block times `p` (the WGSL's `contact_times`).
    #[inline(always)]
    pub fn times(&self, p: Vec3) -> Vec3 {
        let (d, o) = (self.diag, self.off);
        Vec3::new(
            d.x * p.x + o.x * p.y + o.y * p.z,
            o.x * p.x + d.y * p.y + o.z * p.z,
            o.y * p.x + o.z * p.y + d.z * p.z,
        )
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

/// `m` times `v`, its columns weighted and added in this order (the WGSL's `block_times`).
/// Written out rather than as `m * v`, whose order is the compiler's: glam adds the columns
/// first to last, while Mesa's SPIR-V translation (lavapipe) adds them last to first, so the
/// two parted at the last bit of implicit Euler's preconditioned residual.
#[inline(always)]
pub fn block_times(m: Mat3, v: Vec3) -> Vec3 {
    m.x_axis * v.x + m.y_axis * v.y + m.z_axis * v.z
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
