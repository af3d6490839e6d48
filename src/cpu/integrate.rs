//! One step of each integrator. Every stage evaluates the whole force through
//! [`compute_forces`]. Mirrors the entry points of `shaders/integrate.wgsl`.

use glam::Vec3;
use rayon::prelude::*;

use super::forces::{CHUNK, Gather, PARALLEL_MIN_MASSES, compute_forces};
use crate::integrator::Integrator;
use crate::model::Model;
use crate::state::{Power, State};

/// Scratch buffers, allocated once per backend.
#[derive(Debug, Default)]
pub struct Scratch {
    acc: Vec<Vec3>,
    xt: Vec<Vec3>,
    vt: Vec<Vec3>,
    sum_v: Vec<Vec3>,
    sum_a: Vec<Vec3>,
    /// Verlet's acceleration (and ledger rates) at the current state, from the previous step.
    verlet_cache: Option<Power>,
    gather: Gather,
    /// Per spring with the relaxation of this dt, when springs change during the run.
    limits: Vec<crate::model::SpringLimits>,
    /// Only for the implicit integrator.
    implicit: Option<super::implicit::ImplicitWork>,
}

impl Scratch {
    pub fn new(model: &Model, dt_secs: f64) -> Self {
        let n = model.mass_count();
        Self {
            gather: Gather::new(model),
            limits: model.spring_limits(dt_secs),
            implicit: None,
            acc: vec![Vec3::ZERO; n],
            xt: vec![Vec3::ZERO; n],
            vt: vec![Vec3::ZERO; n],
            sum_v: vec![Vec3::ZERO; n],
            sum_a: vec![Vec3::ZERO; n],
            verlet_cache: None,
        }
    }
}

impl Scratch {
    /// The springs as they are now.
    pub fn springs(&self) -> &[crate::model::Spring] {
        self.gather.springs()
    }

    /// Plastic flow and tearing after a step (see [`super::update_springs`]).
    pub fn update_springs(&mut self, state: &mut State) {
        state.ledger.plastic_j += super::update_springs(&self.limits, &mut self.gather, &state.x);
    }
}

/// Apply `f(i, ...)` to every index of equally long slices, in parallel for large models. Each
/// element is written by exactly one call, so the result does not depend on scheduling.
macro_rules! for_each_mass {
    ($n:expr, |$i:ident| ($($out:ident),+) $body:block) => {{
        let n = $n;
        if n >= PARALLEL_MIN_MASSES {
            #[allow(unused_parens)]
            ($($out.par_chunks_mut(CHUNK)),+).into_par_iter().enumerate().for_each(|(c, ($($out),+))| {
                for k in 0..CHUNK.min(n - c * CHUNK) {
                    let $i = c * CHUNK + k;
                    $(let $out = &mut $out[k];)+
                    $body
                }
            });
        } else {
            for $i in 0..n {
                $(let $out = &mut $out[$i];)+
                $body
            }
        }
    }};
}

/// Advance `state` by one step of `dt`; the implicit integrator reports its linear solve.
pub fn step(
    model: &Model,
    integrator: Integrator,
    state: &mut State,
    s: &mut Scratch,
    dt: f32,
) -> Option<super::implicit::SolveStats> {
    if integrator == Integrator::Implicit {
        let work = s
            .implicit
            .get_or_insert_with(|| super::implicit::ImplicitWork::new(model));
        return Some(super::implicit::implicit_step(
            model,
            &mut s.gather,
            state,
            work,
            dt,
        ));
    }
    let n = state.x.len();
    let t = state.time_secs;
    let h = f64::from(dt);
    let State { x, v, ledger, .. } = state;
    let (x, v) = (&mut x[..], &mut v[..]);
    match integrator {
        Integrator::Euler => {
            let p = compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
            let acc = &s.acc;
            for_each_mass!(n, |i| (x, v) {
                *x += dt * *v;
                *v += dt * acc[i];
            });
            ledger.accumulate(&p, h);
        }
        Integrator::SemiImplicit => {
            let p = compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
            let acc = &s.acc;
            for_each_mass!(n, |i| (x, v) {
                *v += dt * acc[i];
                *x += dt * *v;
            });
            ledger.accumulate(&p, h);
        }
        Integrator::Rk2 => {
            compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
            let (acc, xt, vt) = (&s.acc, &mut s.xt[..], &mut s.vt[..]);
            {
                let (x, v) = (&*x, &*v);
                for_each_mass!(n, |i| (xt, vt) {
                    *xt = x[i] + 0.5 * dt * v[i];
                    *vt = v[i] + 0.5 * dt * acc[i];
                });
            }
            let p = compute_forces(
                model,
                &mut s.gather,
                &s.xt,
                &s.vt,
                t + 0.5 * h,
                dt,
                &mut s.acc,
            );
            let (acc, vt) = (&s.acc, &s.vt);
            for_each_mass!(n, |i| (x, v) {
                *x += dt * vt[i];
                *v += dt * acc[i];
            });
            ledger.accumulate(&p, h);
        }
        Integrator::Rk4 => {
            let mut power = Power::default();
            // Stage 1 at (x, v).
            let p = compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
            power.add_scaled(&p, 1.0);
            {
                let (x, v, acc) = (&*x, &*v, &s.acc);
                let (xt, vt, sv, sa) = (
                    &mut s.xt[..],
                    &mut s.vt[..],
                    &mut s.sum_v[..],
                    &mut s.sum_a[..],
                );
                for_each_mass!(n, |i| (xt, vt, sv, sa) {
                    *sv = v[i];
                    *sa = acc[i];
                    *xt = x[i] + 0.5 * dt * v[i];
                    *vt = v[i] + 0.5 * dt * acc[i];
                });
            }
            // Stages 2 and 3 at the midpoint; stage 4 at the end.
            for (stage_t, next_scale, weight) in [(0.5, 0.5f32, 2.0f32), (0.5, 1.0, 2.0)] {
                let p = compute_forces(
                    model,
                    &mut s.gather,
                    &s.xt,
                    &s.vt,
                    t + stage_t * h,
                    dt,
                    &mut s.acc,
                );
                power.add_scaled(&p, f64::from(weight));
                let (x, v, acc) = (&*x, &*v, &s.acc);
                let (xt, vt, sv, sa) = (
                    &mut s.xt[..],
                    &mut s.vt[..],
                    &mut s.sum_v[..],
                    &mut s.sum_a[..],
                );
                for_each_mass!(n, |i| (xt, vt, sv, sa) {
                    *sv += weight * *vt;
                    *sa += weight * acc[i];
                    *xt = x[i] + next_scale * dt * *vt;
                    *vt = v[i] + next_scale * dt * acc[i];
                });
            }
            let p = compute_forces(model, &mut s.gather, &s.xt, &s.vt, t + h, dt, &mut s.acc);
            power.add_scaled(&p, 1.0);
            let (acc, vt, sv, sa) = (&s.acc, &s.vt, &s.sum_v, &s.sum_a);
            for_each_mass!(n, |i| (x, v) {
                *x += (dt / 6.0) * (sv[i] + vt[i]);
                *v += (dt / 6.0) * (sa[i] + acc[i]);
            });
            ledger.accumulate(&power, h / 6.0);
        }
        Integrator::Verlet => {
            // a(x_n) is kept in `acc` from the previous step.
            let p0 = match s.verlet_cache {
                Some(p) => p,
                None => compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc),
            };
            {
                let acc = &s.acc;
                let (xt, vt) = (&mut s.xt[..], &mut s.vt[..]);
                // Kick-drift-kick: every update has the shape p + s·q, which compilers do not
                // fuse differently on CPU and GPU (dt·v + ½dt²·a would become an FMA on some).
                for_each_mass!(n, |i| (x, xt, vt) {
                    let half_kick = v[i] + (0.5 * dt) * acc[i];
                    *x += dt * half_kick;
                    // Predicted velocity for the velocity-dependent forces at the new position.
                    *vt = v[i] + dt * acc[i];
                    *xt = half_kick;
                });
            }
            let p1 = compute_forces(model, &mut s.gather, x, &s.vt, t + h, dt, &mut s.acc);
            let (acc, half_kick) = (&s.acc, &s.xt);
            for_each_mass!(n, |i| (v) {
                *v = half_kick[i] + (0.5 * dt) * acc[i];
            });
            ledger.accumulate(&p0, 0.5 * h);
            ledger.accumulate(&p1, 0.5 * h);
            s.verlet_cache = Some(p1);
        }
        Integrator::Implicit => unreachable!("handled above"),
    }
    state.time_secs += h;
    state.steps += 1;
    None
}
