//! `fused_step`: one explicit or semi-implicit Euler step in a single pass over the masses —
//! the spring gather of `compute_forces`, gravity and drag, `euler_update` /
//! `semi_implicit_update`, the ledger's rates and a first look for divergence — on a
//! structure-of-arrays copy of the state, read from one buffer and written to the other
//! (ping-pong). Masses that share a stencil (`stencil.rs`) are computed in SIMD lanes, one mass
//! per lane, chosen at run time (AVX2, else SSE2; a portable array on other targets).
//!
//! Each mass's arithmetic is the scalar code's, operation for operation and in the same order
//! (its springs in CSR order, as `compute_forces` in src/cpu/forces.rs and shaders/forces.wgsl
//! sum them), and the ledger is summed per chunk in mass order as there: the result is
//! bit-identical to `compute_forces` followed by the update (tests/fused.rs). The fused pass
//! serves models whose only forces are springs, gravity and drag ([`FusedStep::serves`]); any
//! other goes through the general path.

use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use super::fused_chunk::{ChunkOut, Input, Output, chunk};
use super::lanes::Portable;
use super::stencil::Stencils;
use crate::integrator::{Explicit, Integrator};
use crate::model::Model;
use crate::state::Power;

/// Which lanes the fused step computes with. `Best` is what the CPU offers; the others exist so
/// that tests can hold every kernel to the same result on one machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Simd {
    /// AVX2 where the CPU has it, else SSE2 (x86-64), else the portable lanes.
    Best,
    /// 8 lanes; falls back to `Best` on a CPU without AVX2.
    Avx2,
    /// 4 lanes (x86-64 only; falls back to `Portable` elsewhere).
    Sse2,
    /// 4 lanes in a plain array, for any target.
    Portable,
    /// One mass at a time, the same code at width 1.
    Scalar,
}

impl Simd {
    /// What `self` runs on this CPU.
    pub fn resolve(self) -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2");
            match self {
                Simd::Best | Simd::Avx2 if avx2 => Simd::Avx2,
                Simd::Best | Simd::Avx2 => Simd::Sse2,
                k => k,
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        match self {
            Simd::Best | Simd::Avx2 | Simd::Sse2 => Simd::Portable,
            k => k,
        }
    }
}

/// Positions and velocities, one array per coordinate: `[x, y, z, vx, vy, vz]`.
#[derive(Debug, Default, Clone)]
struct Soa([Vec<f32>; 6]);

impl Soa {
    fn load(&mut self, x: &[glam::Vec3], v: &[glam::Vec3]) {
        for (k, a) in self.0.iter_mut().enumerate() {
            let src = if k < 3 { x } else { v };
            a.clear();
            a.extend(src.iter().map(|p| p[k % 3]));
        }
    }

    fn unload(&self, x: &mut [glam::Vec3], v: &mut [glam::Vec3]) {
        let [px, py, pz, vx, vy, vz] = &self.0;
        for (i, (p, q)) in x.iter_mut().zip(v.iter_mut()).enumerate() {
            *p = glam::Vec3::new(px[i], py[i], pz[i]);
            *q = glam::Vec3::new(vx[i], vy[i], vz[i]);
        }
    }
}

/// The fused step's tables and buffers, made once per backend.
#[derive(Debug)]
pub struct FusedStep {
    stencils: Stencils,
    kernel: Simd,
    /// The state at the step's start and the one it writes.
    now: Soa,
    next: Soa,
    semi_implicit: bool,
}

impl FusedStep {
    /// Whether the fused step computes exactly what the general path would for this model and
    /// integrator: springs that never change, and no force but springs, gravity and drag.
    pub fn serves(model: &Model, integrator: Integrator) -> bool {
        let e = &model.effects;
        matches!(
            integrator.scheme().explicit(),
            Some(Explicit::OneUpdate { .. })
        ) && !e.has_contact()
            && !e.springs_change()
            && e.self_collision.is_none()
    }

    pub(crate) fn new(model: &Model, integrator: Integrator, kernel: Simd) -> Self {
        Self {
            stencils: Stencils::new(model),
            kernel: kernel.resolve(),
            now: Soa::default(),
            next: Soa::default(),
            semi_implicit: integrator.scheme().explicit()
                == Some(Explicit::OneUpdate { symplectic: true }),
        }
    }

    /// The kernel this step runs.
    pub fn simd(&self) -> Simd {
        self.kernel
    }

    /// Share of the masses computed in lanes.
    pub fn run_share(&self) -> f64 {
        self.stencils.run_share()
    }

    /// Take the state to step from.
    pub(crate) fn load(&mut self, x: &[glam::Vec3], v: &[glam::Vec3]) {
        self.now.load(x, v);
        for a in &mut self.next.0 {
            a.resize(x.len(), 0.0);
        }
    }

    /// Write the current state back.
    pub(crate) fn unload(&self, x: &mut [glam::Vec3], v: &mut [glam::Vec3]) {
        self.now.unload(x, v);
    }

    /// One step of `dt`; returns the ledger's rates at the step's start and whether a mass may
    /// have diverged (then `unload` and ask `find_divergence`).
    pub(crate) fn fused_step(&mut self, model: &Model, dt: f32) -> (Power, bool) {
        let e = &model.effects;
        let input = Input {
            s: &self.now.0,
            mass: &model.mass_kg,
            inv_mass: &model.inv_mass,
            gravity: e.gravity_m_per_s2.map(|g| g.to_array()),
            drag: e.air_drag_per_s,
            dt,
            semi_implicit: self.semi_implicit,
        };
        let (stencils, kernel) = (&self.stencils, self.kernel);
        let run = |(c, out): (usize, [&mut [f32]; 6])| -> ChunkOut {
            let mut out = Output {
                s: out,
                lo: c * CHUNK,
            };
            run_chunk(kernel, stencils, &input, &mut out, c)
        };
        let per_chunk: Vec<ChunkOut> = if model.mass_count() >= PARALLEL_MIN_MASSES {
            let [a, b, c, d, f, g] = &mut self.next.0;
            let chunks = (
                a.par_chunks_mut(CHUNK),
                b.par_chunks_mut(CHUNK),
                c.par_chunks_mut(CHUNK),
                d.par_chunks_mut(CHUNK),
                f.par_chunks_mut(CHUNK),
                g.par_chunks_mut(CHUNK),
            );
            chunks
                .into_par_iter()
                .map(|(a, b, c, d, f, g)| [a, b, c, d, f, g])
                .enumerate()
                .map(run)
                .collect()
        } else {
            let [a, b, c, d, f, g] = &mut self.next.0;
            let serial = a
                .chunks_mut(CHUNK)
                .zip(b.chunks_mut(CHUNK))
                .zip(c.chunks_mut(CHUNK))
                .zip(d.chunks_mut(CHUNK))
                .zip(f.chunks_mut(CHUNK))
                .zip(g.chunks_mut(CHUNK));
            serial
                .map(|(((((a, b), c), d), f), g)| [a, b, c, d, f, g])
                .enumerate()
                .map(run)
                .collect()
        };
        std::mem::swap(&mut self.now, &mut self.next);
        // Chunk sums added in chunk order, as `compute_forces` adds them.
        let mut total = [0.0f64; 4];
        let mut suspect = false;
        for (sum, bad) in per_chunk {
            for (t, q) in total.iter_mut().zip(sum) {
                *t += q;
            }
            suspect |= bad;
        }
        let power = Power {
            damping_w: total[0],
            drag_w: total[1],
            contact_w: total[2],
            collider_w: total[3],
        };
        (power, suspect)
    }
}

fn run_chunk(
    kernel: Simd,
    stencils: &Stencils,
    input: &Input,
    out: &mut Output,
    c: usize,
) -> ChunkOut {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Simd::resolve` gives Avx2 only where the CPU has AVX2.
        Simd::Avx2 => unsafe { chunk_avx2(stencils, input, out, c) },
        #[cfg(target_arch = "x86_64")]
        Simd::Sse2 => chunk::<super::lanes::Sse2>(stencils, input, out, c),
        Simd::Scalar => chunk::<f32>(stencils, input, out, c),
        _ => chunk::<Portable>(stencils, input, out, c),
    }
}

/// The chunk compiled for AVX2: the lanes' intrinsics inline into it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn chunk_avx2(stencils: &Stencils, input: &Input, out: &mut Output, c: usize) -> ChunkOut {
    chunk::<super::lanes::Avx>(stencils, input, out, c)
}
