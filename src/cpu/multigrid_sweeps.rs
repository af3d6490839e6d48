//! Multigrid's sweeps on one level (weighted Jacobi with each mass's 3 × 3 block) and the dense
//! Cholesky factor of the coarsest level.

use glam::{Mat3, Vec3};

use super::chunks::each_mass as each;
use super::system_blocks::block_times;
use crate::physics::hierarchy::SMOOTHING;

/// Factors the symmetric `n` × `n` matrix `a` (row-major) into its lower Cholesky factor in
/// place; false if it is not positive definite.
pub(super) fn cholesky_in_place(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let d = a[j * n + j] - (0..j).map(|k| a[j * n + k] * a[j * n + k]).sum::<f64>();
        if d.is_nan() || d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let s = a[i * n + j] - (0..j).map(|k| a[i * n + k] * a[j * n + k]).sum::<f64>();
            a[i * n + j] = s / d;
        }
    }
    true
}

/// x = ω D⁻¹ b (a sweep from zero).
pub(super) fn smooth_from_zero(diag_inv: &[Mat3], b: &[Vec3], x: &mut [Vec3]) {
    each(x, |i, out| {
        *out = SMOOTHING * block_times(diag_inv[i], b[i])
    });
}

/// r = b − A x, given ax = A x.
pub(super) fn residual(b: &[Vec3], ax: &[Vec3], r: &mut [Vec3]) {
    each(r, |i, out| *out = b[i] - ax[i]);
}

/// x += ω D⁻¹ r.
pub(super) fn smooth(diag_inv: &[Mat3], r: &[Vec3], x: &mut [Vec3]) {
    each(x, |i, out| {
        *out += SMOOTHING * block_times(diag_inv[i], r[i])
    });
}
