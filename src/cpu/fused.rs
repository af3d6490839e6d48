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
use super::lanes::{Lanes, Portable};
use super::stencil::{Segment, Stencils};
use crate::backend::RUNAWAY_SPEED_M_PER_S;
use crate::integrator::Integrator;
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

/// What one chunk reports: its ledger rates, summed in f64 in mass order, and whether some mass
/// may have diverged (non-finite, or a speed near the runaway bound: `find_divergence` decides).
type ChunkOut = ([f64; 4], bool);

impl FusedStep {
    /// Whether the fused step computes exactly what the general path would for this model and
    /// integrator: springs that never change, and no force but springs, gravity and drag.
    pub fn serves(model: &Model, integrator: Integrator) -> bool {
        let e = &model.effects;
        matches!(integrator, Integrator::Euler | Integrator::SemiImplicit)
            && !e.has_contact()
            && !e.springs_change()
            && e.self_collision.is_none()
    }

    pub(crate) fn new(model: &Model, integrator: Integrator, kernel: Simd) -> Self {
        Self {
            stencils: Stencils::new(model),
            kernel: kernel.resolve(),
            now: Soa::default(),
            next: Soa::default(),
            semi_implicit: integrator == Integrator::SemiImplicit,
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

/// What the pass reads: the state at the step's start and the per-mass constants.
struct Input<'a> {
    s: &'a [Vec<f32>; 6],
    mass: &'a [f32],
    inv_mass: &'a [f32],
    gravity: Option<[f32; 3]>,
    drag: Option<f32>,
    dt: f32,
    semi_implicit: bool,
}

/// One chunk of the new state: `s[k][i - lo]` is coordinate `k` of mass `i`.
struct Output<'a> {
    s: [&'a mut [f32]; 6],
    lo: usize,
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

/// Chunk `c`'s masses in order: runs in lanes of `L`, the others one at a time.
#[inline(always)]
fn chunk<L: Lanes>(stencils: &Stencils, input: &Input, out: &mut Output, c: usize) -> ChunkOut {
    let mut sum = [0.0f64; 4];
    let mut ok = true;
    for seg in stencils.of_chunk(c) {
        match *seg {
            Segment::Run {
                start,
                end,
                stencil,
                rest_at,
            } if end - start >= L::WIDTH => {
                let slots = &stencils.stencils[stencil];
                let stride = end - start;
                let mut booked = start;
                while booked < end {
                    // The last block may overlap the one before: it recomputes (and rewrites)
                    // the same values, and books only the masses not booked yet.
                    let at = booked.min(end - L::WIDTH);
                    let f = gather_run::<L>(
                        slots,
                        &stencils.rest,
                        rest_at + at - start,
                        stride,
                        input,
                        at,
                    );
                    let (rates, fine) = finish::<L>(f, input, out, at);
                    ok &= fine;
                    book(&mut sum, rates, booked - at, input.drag.is_some());
                    booked = at + L::WIDTH;
                }
            }
            Segment::Run { start, end, .. } | Segment::Single { start, end, .. } => {
                for i in start..end {
                    let f = gather_one(stencils, seg, input, i);
                    let (rates, fine) = finish::<f32>(f, input, out, i);
                    ok &= fine;
                    book(&mut sum, rates, 0, input.drag.is_some());
                }
            }
        }
    }
    (sum, !ok)
}

/// Add lanes `from..` of the (damping, drag) rates into the chunk's sums, in mass order, as
/// `compute_forces` adds each mass's. Its contact and collider rates are zero here, and so is
/// drag's without drag: adding a zero to a sum that started at +0 changes no bit, so only what
/// can be nonzero is added.
#[inline(always)]
fn book<L: Lanes>(sum: &mut [f64; 4], rates: [L; 2], from: usize, drag: bool) {
    let mut lanes = [[0.0f32; 8]; 2];
    rates[0].store(&mut lanes[0], 0);
    rates[1].store(&mut lanes[1], 0);
    for &r in &lanes[0][from..L::WIDTH] {
        sum[0] += f64::from(r);
    }
    if drag {
        for &r in &lanes[1][from..L::WIDTH] {
            sum[1] += f64::from(r);
        }
    }
}

/// The springs' force on masses `at..at + WIDTH` and their dashpots' power, with their state.
struct Gathered<L> {
    x: [L; 3],
    v: [L; 3],
    f: [L; 3],
    damping_w: L,
}

/// A damped spring's force on the mass at (`x`, `v`) from its other end at (`xj`, `vj`), added
/// into `g`: `spring_force` in src/cpu/law.rs, lane by lane, operation for operation.
#[inline(always)]
fn spring_end<L: Lanes>(g: &mut Gathered<L>, xj: [L; 3], vj: [L; 3], rest: L, neg_k: L, neg_c: L) {
    let (x, v) = (g.x, g.v);
    let d = [x[0] - xj[0], x[1] - xj[1], x[2] - xj[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let inv = L::splat(1.0).div(len);
    let n = [d[0] * inv, d[1] * inv, d[2] * inv];
    let elastic = neg_k * (len - rest);
    let dv = [v[0] - vj[0], v[1] - vj[1], v[2] - vj[2]];
    let damping = neg_c * (dv[0] * n[0] + dv[1] * n[1] + dv[2] * n[2]);
    let s = elastic + damping;
    let fs = [n[0] * s, n[1] * s, n[2] * s];
    let pw = damping * (n[0] * v[0] + n[1] * v[1] + n[2] * v[2]);
    // A spring too short to have a direction exerts nothing (and NaN lengths go through, as in
    // the scalar code).
    let skip = len.le(L::splat(<f32 as super::law::Real>::MIN_SPRING_LENGTH));
    if L::no(skip) {
        for (f, q) in g.f.iter_mut().zip(fs) {
            *f = *f + q;
        }
        g.damping_w = g.damping_w + pw;
    } else {
        for (f, q) in g.f.iter_mut().zip(fs) {
            *f = L::select(skip, *f, *f + q);
        }
        g.damping_w = L::select(skip, g.damping_w, g.damping_w + pw);
    }
}

#[inline(always)]
fn load3<L: Lanes>(s: &[Vec<f32>], at: usize) -> [L; 3] {
    [L::load(&s[0], at), L::load(&s[1], at), L::load(&s[2], at)]
}

/// Masses `at..at + WIDTH` of a run: every lane has the same neighbour offsets and constants.
#[inline(always)]
fn gather_run<L: Lanes>(
    slots: &[super::stencil::Slot],
    rest: &[f32],
    rest_at: usize,
    stride: usize,
    input: &Input,
    at: usize,
) -> Gathered<L> {
    let (xs, vs) = input.s.split_at(3);
    let mut g = Gathered {
        x: load3::<L>(xs, at),
        v: load3::<L>(vs, at),
        f: [L::splat(0.0); 3],
        damping_w: L::splat(0.0),
    };
    for (s, slot) in slots.iter().enumerate() {
        let j = at.wrapping_add_signed(slot.delta);
        let rest = L::load(rest, rest_at + s * stride);
        let (neg_k, neg_c) = (L::splat(slot.neg_stiffness), L::splat(slot.neg_damping));
        spring_end(&mut g, load3(xs, j), load3(vs, j), rest, neg_k, neg_c);
    }
    g
}

/// Mass `i` of a segment, through its own list of springs.
#[inline(always)]
fn gather_one(stencils: &Stencils, seg: &Segment, input: &Input, i: usize) -> Gathered<f32> {
    let (xs, vs) = input.s.split_at(3);
    let mut g = Gathered {
        x: load3::<f32>(xs, i),
        v: load3::<f32>(vs, i),
        f: [0.0; 3],
        damping_w: 0.0,
    };
    let o = &stencils.offsets;
    match *seg {
        Segment::Single {
            start, entry_at, ..
        } => {
            let first = entry_at + (o[i] - o[start]) as usize;
            let count = (o[i + 1] - o[i]) as usize;
            for e in &stencils.entries[first..first + count] {
                let j = e.other as usize;
                spring_end(
                    &mut g,
                    load3(xs, j),
                    load3(vs, j),
                    e.rest_m,
                    e.neg_stiffness,
                    e.neg_damping,
                );
            }
        }
        Segment::Run {
            start,
            end,
            stencil,
            rest_at,
        } => {
            // A run shorter than the lanes: its masses one by one, with the run's tables.
            let stride = end - start;
            for (s, slot) in stencils.stencils[stencil].iter().enumerate() {
                let j = i.wrapping_add_signed(slot.delta);
                let rest = stencils.rest[rest_at + s * stride + i - start];
                spring_end(
                    &mut g,
                    load3(xs, j),
                    load3(vs, j),
                    rest,
                    slot.neg_stiffness,
                    slot.neg_damping,
                );
            }
        }
    }
    g
}

/// Gravity and drag, the update, the ledger's rates and the divergence look for masses
/// `at..at + WIDTH`: the rest of `force_on_mass` (src/cpu/forces.rs) and `euler_update` /
/// `semi_implicit_update` (src/cpu/integrate.rs), in their order.
#[inline(always)]
fn finish<L: Lanes>(g: Gathered<L>, input: &Input, out: &mut Output, at: usize) -> ([L; 2], bool) {
    let Gathered {
        x,
        v,
        mut f,
        damping_w,
    } = g;
    let m = L::load(input.mass, at);
    if let Some(gr) = input.gravity {
        for k in 0..3 {
            f[k] = f[k] + m * L::splat(gr[k]);
        }
    }
    let mut drag_w = L::splat(0.0);
    if let Some(gamma) = input.drag {
        let s = -m * L::splat(gamma);
        let fd = [s * v[0], s * v[1], s * v[2]];
        for k in 0..3 {
            f[k] = f[k] + fd[k];
        }
        drag_w = fd[0] * v[0] + fd[1] * v[1] + fd[2] * v[2];
    }
    // A pinned mass has no acceleration and books nothing.
    let w = L::load(input.inv_mass, at);
    let zero = L::splat(0.0);
    let pinned = w.eq(zero);
    // Written out, not through closures or `map`: whatever is not inlined into the AVX2 chunk
    // is compiled without AVX, and its intrinsics become calls.
    let a = [
        L::select(pinned, zero, f[0] * w),
        L::select(pinned, zero, f[1] * w),
        L::select(pinned, zero, f[2] * w),
    ];
    let rates = [
        L::select(pinned, zero, -damping_w),
        L::select(pinned, zero, -drag_w),
    ];
    let dt = L::splat(input.dt);
    let (mut nx, mut nv) = (x, v);
    for k in 0..3 {
        if input.semi_implicit {
            nv[k] = v[k] + dt * a[k];
            nx[k] = x[k] + dt * nv[k];
        } else {
            nx[k] = x[k] + dt * v[k];
            nv[k] = v[k] + dt * a[k];
        }
    }
    let local = at - out.lo;
    for k in 0..3 {
        nx[k].store(out.s[k], local);
        nv[k].store(out.s[3 + k], local);
    }
    // Finite positions (x · 0 = 0; NaN for an infinity or a NaN) and a speed within the
    // runaway bound pass; anything else is for `find_divergence` to judge exactly.
    let speed2 = nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2];
    let bound = RUNAWAY_SPEED_M_PER_S * RUNAWAY_SPEED_M_PER_S;
    let mut fine = speed2.le(L::splat(bound));
    for p in nx {
        fine = L::and(fine, (p * zero).eq(zero));
    }
    (rates, L::all(fine))
}
