//! One chunk of masses of the fused step: runs of masses that share a stencil in SIMD lanes, the
//! others one at a time, each mass's arithmetic the scalar code's, operation for operation.

use super::lanes::Lanes;
use super::stencil::{Segment, Stencils};
use crate::backend::RUNAWAY_SPEED_M_PER_S;

/// What one chunk reports: its ledger rates, summed in f64 in mass order, and whether some mass
/// may have diverged (non-finite, or a speed near the runaway bound: `find_divergence` decides).
pub(super) type ChunkOut = ([f64; 4], bool);

/// What the pass reads: the state at the step's start and the per-mass constants.
pub(super) struct Input<'a> {
    pub(super) s: &'a [Vec<f32>; 6],
    pub(super) mass: &'a [f32],
    pub(super) inv_mass: &'a [f32],
    pub(super) gravity: Option<[f32; 3]>,
    pub(super) drag: Option<f32>,
    pub(super) dt: f32,
    pub(super) semi_implicit: bool,
}

/// One chunk of the new state: `s[k][i - lo]` is coordinate `k` of mass `i`.
pub(super) struct Output<'a> {
    pub(super) s: [&'a mut [f32]; 6],
    pub(super) lo: usize,
}

/// Chunk `c`'s masses in order: runs in lanes of `L`, the others one at a time.
#[inline(always)]
pub(super) fn chunk<L: Lanes>(
    stencils: &Stencils,
    input: &Input,
    out: &mut Output,
    c: usize,
) -> ChunkOut {
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
