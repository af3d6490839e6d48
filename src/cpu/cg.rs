//! The steps of implicit Euler's and BDF2's conjugate gradients on the CPU, on bare vectors:
//! when to go on (inexact Newton's forcing, or the cap), the update of δ, r and z, and the new
//! direction. `cpu/implicit.rs`'s `solve` runs them on the system it linearises; the GPU's
//! namesakes (`cg_update`, `cg_direction`) run the same arithmetic in shaders/implicit.wgsl.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES, each_mass, each_mass_pair};
use super::system_blocks::block_times;
use crate::physics::{CG_FORCING, CG_FORCING_AT_RESTART, CG_MAX_ITERATIONS};

/// Whether CG goes on at `residual` (|r| relative to the Newton residual |b| it started from)
/// after `iterations` iterations: until `forcing` of |b| (inexact Newton; `cg_forcing`) or its
/// cap.
pub fn cg_goes_on(residual: f32, iterations: u32, forcing: f32) -> bool {
    residual > forcing && iterations < CG_MAX_ITERATIONS
}

/// The step's forcing: CG_FORCING, or CG_FORCING_AT_RESTART in a step BDF2 restarts with (in
/// f32, as the shaders' overrides hold them; their `cg_forcing` reads the restart from the
/// device).
pub fn cg_forcing(restarted: bool) -> f32 {
    if restarted {
        CG_FORCING_AT_RESTART as f32
    } else {
        CG_FORCING as f32
    }
}

/// A solve whose p·Ap is not positive and finite stops where it is.
pub fn usable_curvature(pap: f32) -> bool {
    pap > 0.0 && pap <= f32::MAX
}

/// δ += α p, r −= α Ap, z = B⁻¹ r (B the block diagonal).
pub fn cg_update(
    alpha: f32,
    (p, ap, block_inv): (&[Vec3], &[Vec3], &[Mat3]),
    (dv, r, z): (&mut [Vec3], &mut [Vec3], &mut [Vec3]),
) {
    let n = p.len();
    type Chunks<'a> = ((&'a mut [Vec3], &'a mut [Vec3]), &'a mut [Vec3]);
    let body = |(c, ((dv, r), z)): (usize, Chunks<'_>)| {
        for k in 0..dv.len() {
            let i = c * CHUNK + k;
            dv[k] += alpha * p[i];
            r[k] -= alpha * ap[i];
            z[k] = block_times(block_inv[i], r[k]);
        }
    };
    if n >= PARALLEL_MIN_MASSES {
        dv.par_chunks_mut(CHUNK)
            .zip(r.par_chunks_mut(CHUNK))
            .zip(z.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(body);
    } else {
        dv.chunks_mut(CHUNK)
            .zip(r.chunks_mut(CHUNK))
            .zip(z.chunks_mut(CHUNK))
            .enumerate()
            .for_each(body);
    }
}

/// δ += α p, r −= α Ap (the multigrid preconditioner then makes z from r).
pub(super) fn cg_update_unpreconditioned(
    alpha: f32,
    (p, ap): (&[Vec3], &[Vec3]),
    (dv, r): (&mut [Vec3], &mut [Vec3]),
) {
    each_mass_pair(dv, r, |i, d, r| {
        *d += alpha * p[i];
        *r -= alpha * ap[i];
    });
}

/// p = z + β p.
pub fn cg_direction(beta: f32, z: &[Vec3], p: &mut [Vec3]) {
    each_mass(p, |i, p| *p = z[i] + beta * *p);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_solve_stops_at_a_share_of_its_start_or_at_its_cap() {
        let forcing = cg_forcing(false);
        assert!(cg_goes_on(CG_FORCING as f32 * 1.01, 0, forcing));
        assert!(!cg_goes_on(CG_FORCING as f32 * 0.99, 0, forcing));
        assert!(!cg_goes_on(1.0, CG_MAX_ITERATIONS, forcing));
        assert!(cg_goes_on(CG_FORCING as f32 * 0.99, 0, cg_forcing(true)));
        assert!(!usable_curvature(0.0) && !usable_curvature(f32::INFINITY));
        assert!(!usable_curvature(f32::NAN) && usable_curvature(1.0));
    }
}
