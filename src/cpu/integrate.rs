//! One step of each integrator. Every stage evaluates the whole force through
//! [`compute_forces`]. Mirrors the entry points of `shaders/integrate.wgsl`.

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use super::forces::{Gather, compute_external_forces, compute_forces};
use super::implicit::implicit_step;
use super::implicit_work::{ImplicitWork, SolveStats};
use super::springs::update_springs;
use super::vbd::{VbdWork, vbd_step};
use super::xpbd::XpbdWork;
use crate::backend::StopFlags;
use crate::integrator::{Integrator, Step, StepOptions};
use crate::model::Model;
use crate::physics::Preconditioner;
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
    implicit: Option<ImplicitWork>,
    /// What preconditions its conjugate gradients.
    preconditioner: Preconditioner,
    /// Only for XPBD.
    xpbd: Option<XpbdWork>,
    /// Only for VBD.
    vbd: Option<VbdWork>,
    options: StepOptions,
    dt_secs: f64,
    /// What cuts a step's iterations short (`Backend::watch`).
    stop: StopFlags,
}

impl Scratch {
    pub fn new(model: &Model, step: Step) -> Self {
        let Step {
            dt_secs, options, ..
        } = step;
        let n = model.mass_count();
        Self {
            gather: Gather::new(model),
            limits: model.spring_limits(dt_secs),
            implicit: None,
            preconditioner: crate::physics::preconditioner_of(model, step),
            xpbd: None,
            vbd: None,
            options,
            dt_secs,
            acc: vec![Vec3::ZERO; n],
            xt: vec![Vec3::ZERO; n],
            vt: vec![Vec3::ZERO; n],
            sum_v: vec![Vec3::ZERO; n],
            sum_a: vec![Vec3::ZERO; n],
            verlet_cache: None,
            stop: StopFlags::default(),
        }
    }
}

impl Scratch {
    /// Cut the iterations of later steps short once one of `flags` is set.
    pub fn watch(&mut self, flags: StopFlags) {
        self.stop = flags;
    }

    /// Whether a stop was asked for.
    pub fn stop_asked(&self) -> bool {
        self.stop.asked()
    }

    /// Precondition implicit Euler's solves with `p` (its scratch is made again at the next
    /// step).
    pub fn set_preconditioner(&mut self, p: Preconditioner) {
        self.preconditioner = p;
        self.implicit = None;
    }

    pub fn preconditioner(&self) -> Preconditioner {
        self.preconditioner
    }

    /// The springs as they are now.
    pub fn springs(&self) -> &[crate::model::Spring] {
        self.gather.springs()
    }

    /// How many times the neighbour lists have been built; `None` without mass–mass contact.
    pub fn neighbour_builds(&self) -> Option<u64> {
        self.gather.neighbour_builds()
    }

    /// Plastic flow and tearing after a step (see [`update_springs`]).
    pub fn update_springs(&mut self, state: &mut State) {
        state.ledger.plastic_j += update_springs(&self.limits, &mut self.gather, &state.x);
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

/// Advance `state` by one step of `dt`; implicit Euler and VBD report their solve.
pub fn step(
    model: &Model,
    integrator: Integrator,
    state: &mut State,
    s: &mut Scratch,
    dt: f32,
) -> Option<SolveStats> {
    match integrator {
        Integrator::Euler | Integrator::SemiImplicit => {
            first_order_step(model, integrator, state, s, dt)
        }
        Integrator::Rk2 => rk2_step(model, state, s, dt),
        Integrator::Rk4 => rk4_step(model, state, s, dt),
        Integrator::Verlet => verlet_step(model, state, s, dt),
        Integrator::Xpbd => xpbd_step(model, state, s, dt),
        // It keeps its own time.
        Integrator::Implicit | Integrator::Bdf2 => {
            let work = s
                .implicit
                .get_or_insert_with(|| ImplicitWork::new(model, s.preconditioner));
            return Some(implicit_step(
                model,
                &mut s.gather,
                state,
                work,
                integrator,
                dt,
                &s.stop,
            ));
        }
        Integrator::Vbd => {
            let iterations = s.options.vbd_iterations;
            let work = s.vbd.get_or_insert_with(|| VbdWork::new(model, iterations));
            return Some(vbd_step(model, &mut s.gather, state, work, dt, &s.stop));
        }
    }
    state.time_secs += f64::from(dt);
    state.steps += 1;
    None
}

fn first_order_step(
    model: &Model,
    integrator: Integrator,
    state: &mut State,
    s: &mut Scratch,
    dt: f32,
) {
    let State {
        x,
        v,
        ledger,
        time_secs,
        ..
    } = state;
    let p = compute_forces(model, &mut s.gather, x, v, *time_secs, dt, &mut s.acc);
    if integrator == Integrator::Euler {
        euler_update(x, v, &s.acc, dt);
    } else {
        semi_implicit_update(x, v, &s.acc, dt);
    }
    ledger.accumulate(&p, f64::from(dt));
}

/// One XPBD substep (src/cpu/xpbd.rs): the kick of every force that is not a spring, then the
/// springs projected as constraints. The dashpots' power at the substep's start, h c (n · v)²
/// per spring, enters the ledger as damping.
fn xpbd_step(model: &Model, state: &mut State, s: &mut Scratch, dt: f32) {
    let State {
        x,
        v,
        ledger,
        time_secs,
        ..
    } = state;
    let p = compute_external_forces(model, &mut s.gather, x, v, *time_secs, dt, &mut s.acc);
    let (h, iterations) = (s.dt_secs, s.options.xpbd_iterations);
    let work = s
        .xpbd
        .get_or_insert_with(|| XpbdWork::new(&model.springs, &model.inv_mass, h, iterations));
    xpbd_predict(v, &mut work.dx, &s.acc, dt);
    work.project(s.gather.springs(), &model.inv_mass, dt, (x, v), &s.stop);
    ledger.accumulate(&p, f64::from(dt));
}

/// XPBD's kick, `v += dt · a` from the forces that are not springs (a pinned mass has none),
/// and its predicted displacement `dx = dt · v`.
pub fn xpbd_predict(v: &mut [Vec3], dx: &mut [Vec3], acc: &[Vec3], dt: f32) {
    let n = v.len();
    for_each_mass!(n, |i| (v, dx) {
        *v += dt * acc[i];
        *dx = dt * *v;
    });
}

fn rk2_step(model: &Model, state: &mut State, s: &mut Scratch, dt: f32) {
    let (t, h) = (state.time_secs, f64::from(dt));
    let State { x, v, ledger, .. } = state;
    compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
    rk2_stage(x, v, &s.acc, dt, &mut s.xt, &mut s.vt);
    let p = compute_forces(
        model,
        &mut s.gather,
        &s.xt,
        &s.vt,
        t + 0.5 * h,
        dt,
        &mut s.acc,
    );
    rk2_final(x, v, &s.acc, &s.vt, dt);
    ledger.accumulate(&p, h);
}

fn rk4_step(model: &Model, state: &mut State, s: &mut Scratch, dt: f32) {
    let (t, h) = (state.time_secs, f64::from(dt));
    let State { x, v, ledger, .. } = state;
    let mut power = Power::default();
    // Stage 1 at (x, v).
    let p = compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc);
    power.add_scaled(&p, 1.0);
    rk4_begin(
        x,
        v,
        &s.acc,
        dt,
        (&mut s.xt, &mut s.vt, &mut s.sum_v, &mut s.sum_a),
    );
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
        let sums = (
            &mut s.xt[..],
            &mut s.vt[..],
            &mut s.sum_v[..],
            &mut s.sum_a[..],
        );
        rk4_mid(x, v, &s.acc, dt, (weight, next_scale), sums);
    }
    let p = compute_forces(model, &mut s.gather, &s.xt, &s.vt, t + h, dt, &mut s.acc);
    power.add_scaled(&p, 1.0);
    rk4_final(x, v, &s.acc, dt, (&s.vt, &s.sum_v, &s.sum_a));
    ledger.accumulate(&power, h / 6.0);
}

fn verlet_step(model: &Model, state: &mut State, s: &mut Scratch, dt: f32) {
    let (t, h) = (state.time_secs, f64::from(dt));
    let State { x, v, ledger, .. } = state;
    // a(x_n) is kept in `acc` from the previous step.
    let p0 = match s.verlet_cache {
        Some(p) => p,
        None => compute_forces(model, &mut s.gather, x, v, t, dt, &mut s.acc),
    };
    verlet_drift(x, v, &s.acc, dt, &mut s.xt, &mut s.vt);
    let p1 = compute_forces(model, &mut s.gather, x, &s.vt, t + h, dt, &mut s.acc);
    verlet_kick(v, &s.acc, &s.xt, dt);
    ledger.accumulate(&p0, 0.5 * h);
    ledger.accumulate(&p1, 0.5 * h);
    s.verlet_cache = Some(p1);
}

pub fn euler_update(x: &mut [Vec3], v: &mut [Vec3], acc: &[Vec3], dt: f32) {
    for_each_mass!(x.len(), |i| (x, v) {
        *x += dt * *v;
        *v += dt * acc[i];
    });
}

pub fn semi_implicit_update(x: &mut [Vec3], v: &mut [Vec3], acc: &[Vec3], dt: f32) {
    for_each_mass!(x.len(), |i| (x, v) {
        *v += dt * acc[i];
        *x += dt * *v;
    });
}

/// The midpoint (xt, vt) from the derivative at the start.
pub fn rk2_stage(x: &[Vec3], v: &[Vec3], acc: &[Vec3], dt: f32, xt: &mut [Vec3], vt: &mut [Vec3]) {
    for_each_mass!(x.len(), |i| (xt, vt) {
        *xt = x[i] + 0.5 * dt * v[i];
        *vt = v[i] + 0.5 * dt * acc[i];
    });
}

/// The step with the midpoint's derivative (`vt`, `acc`).
pub fn rk2_final(x: &mut [Vec3], v: &mut [Vec3], acc: &[Vec3], vt: &[Vec3], dt: f32) {
    for_each_mass!(x.len(), |i| (x, v) {
        *x += dt * vt[i];
        *v += dt * acc[i];
    });
}

/// RK4's stage point and weighted sums: (xt, vt, Σv, Σa).
type Rk4Sums<'a> = (
    &'a mut [Vec3],
    &'a mut [Vec3],
    &'a mut [Vec3],
    &'a mut [Vec3],
);

/// Start the sums with stage 1 and form stage 2's point.
pub fn rk4_begin(x: &[Vec3], v: &[Vec3], acc: &[Vec3], dt: f32, (xt, vt, sv, sa): Rk4Sums<'_>) {
    for_each_mass!(x.len(), |i| (xt, vt, sv, sa) {
        *sv = v[i];
        *sa = acc[i];
        *xt = x[i] + 0.5 * dt * v[i];
        *vt = v[i] + 0.5 * dt * acc[i];
    });
}

/// Stages 2 and 3: add this stage with `weight`, then form the next point at `next_scale` of
/// the step.
pub fn rk4_mid(
    x: &[Vec3],
    v: &[Vec3],
    acc: &[Vec3],
    dt: f32,
    (weight, next_scale): (f32, f32),
    (xt, vt, sv, sa): Rk4Sums<'_>,
) {
    for_each_mass!(x.len(), |i| (xt, vt, sv, sa) {
        *sv += weight * *vt;
        *sa += weight * acc[i];
        *xt = x[i] + next_scale * dt * *vt;
        *vt = v[i] + next_scale * dt * acc[i];
    });
}

/// The step with stage 4 (`vt`, `acc`) and the sums of the others.
pub fn rk4_final(
    x: &mut [Vec3],
    v: &mut [Vec3],
    acc: &[Vec3],
    dt: f32,
    (vt, sv, sa): (&[Vec3], &[Vec3], &[Vec3]),
) {
    for_each_mass!(x.len(), |i| (x, v) {
        *x += (dt / 6.0) * (sv[i] + vt[i]);
        *v += (dt / 6.0) * (sa[i] + acc[i]);
    });
}

/// Kick-drift-kick, first half: half a kick with a(x_n), the drift, and a predicted velocity
/// (into `vt`) for the velocity-dependent forces at the new position; the half-kicked velocity
/// is kept in `half_kick`. Every update has the shape p + s·q, which compilers do not fuse
/// differently on CPU and GPU (dt·v + ½dt²·a would become an FMA on some).
pub fn verlet_drift(
    x: &mut [Vec3],
    v: &[Vec3],
    acc: &[Vec3],
    dt: f32,
    half_kick: &mut [Vec3],
    vt: &mut [Vec3],
) {
    for_each_mass!(x.len(), |i| (x, half_kick, vt) {
        let kicked = v[i] + (0.5 * dt) * acc[i];
        *x += dt * kicked;
        *vt = v[i] + dt * acc[i];
        *half_kick = kicked;
    });
}

/// Second half, after the forces at (x_{n+1}, predicted v).
pub fn verlet_kick(v: &mut [Vec3], acc: &[Vec3], half_kick: &[Vec3], dt: f32) {
    for_each_mass!(v.len(), |i| (v) {
        *v = half_kick[i] + (0.5 * dt) * acc[i];
    });
}
