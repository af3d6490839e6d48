//! Implicit Euler's and BDF2's linear solve on the CPU: preconditioned conjugate gradients on the
//! system `cpu/implicit.rs` linearises, block Jacobi or a multigrid cycle as its preconditioner,
//! ended by inexact Newton's forcing, its cap, or a stop (`Backend::watch`). The GPU's
//! namesakes (`cg_update`, `cg_direction`) run the same arithmetic in shaders/implicit.wgsl.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES, each_mass, each_mass_pair};
use super::implicit::{ImplicitWork, apply_system, dot, own_and_contacts};
use crate::backend::StopFlags;
use crate::model::Model;
use crate::physics::{CG_FORCING, CG_MAX_ITERATIONS};

/// Whether CG goes on at `residual` (|r| relative to the Newton residual |b| it started from)
/// after `iterations` iterations: until CG_FORCING of |b| (inexact Newton) or its cap.
pub fn cg_goes_on(residual: f64, iterations: u32) -> bool {
    residual > CG_FORCING && iterations < CG_MAX_ITERATIONS
}

/// Preconditioned conjugate gradients for the system at the current linearisation, from δ = 0,
/// into `w.dv`, until `cg_goes_on` says or `stop` is asked, `b_norm` being |b|. Returns the
/// iterations and |r| / |b|.
pub(super) fn solve(
    model: &Model,
    w: &mut ImplicitWork,
    (h, b_norm): (f32, f64),
    stop: &StopFlags,
) -> (u32, f64) {
    let ImplicitWork {
        lin,
        b,
        r,
        z,
        p,
        ap,
        dv,
        block_inv,
        multigrid,
        ..
    } = w;
    dv.fill(Vec3::ZERO);
    r.copy_from_slice(b);
    if b_norm == 0.0 {
        return (0, 0.0);
    }
    let drag = model.effects.air_drag_per_s.unwrap_or(0.0);
    if let Some(mg) = multigrid.as_mut() {
        mg.linearise(
            |i| own_and_contacts(model, lin, h, drag, i),
            |s| lin.springs[s].block(),
        );
        mg.cycle(
            block_inv,
            |p, out| apply_system(model, lin, h, p, out),
            r,
            z,
        );
    } else {
        let (r, block_inv) = (&*r, &*block_inv);
        each_mass(z, |i, z| *z = block_inv[i] * r[i]);
    }
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    let mut iterations = 0;
    loop {
        let residual = dot(r, r).sqrt() / b_norm;
        if !cg_goes_on(residual, iterations) || stop.asked() {
            return (iterations, residual);
        }
        iterations += 1;
        apply_system(model, lin, h, p, ap);
        let pap = dot(p, ap);
        if pap <= 0.0 || !pap.is_finite() {
            return (iterations, residual);
        }
        let alpha = (rz / pap) as f32;
        if let Some(mg) = multigrid.as_mut() {
            cg_update_unpreconditioned(alpha, (p, ap), (dv, r));
            mg.cycle(
                block_inv,
                |p, out| apply_system(model, lin, h, p, out),
                r,
                z,
            );
        } else {
            cg_update(alpha, (p, ap, block_inv), (dv, r, z));
        }
        let rz_next = dot(r, z);
        let beta = (rz_next / rz) as f32;
        rz = rz_next;
        cg_direction(beta, z, p);
    }
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
            z[k] = block_inv[i] * r[k];
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
fn cg_update_unpreconditioned(
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
