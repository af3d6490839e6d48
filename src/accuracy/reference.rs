//! The f64 reference solution the accuracy benchmark measures against: the model's full force
//! (springs, gravity, drag, contact with friction, mass–mass contact) evaluated in double precision and integrated
//! by classic RK4 at a step much finer than any it judges. The force laws are the backends' own
//! (`cpu::law`, generic over the precision), so what differs is only precision and step size.

use glam::DVec3;
use rayon::prelude::*;

use crate::cpu::{MassGrid, PARALLEL_MIN_MASSES, contact_force, spring_force};
use crate::model::{MassContact, Model};
use crate::physics::PAIR_STICK_SHARE;

pub struct Reference {
    model: std::sync::Arc<Model>,
    pub x: Vec<DVec3>,
    pub v: Vec<DVec3>,
    pub time_secs: f64,
}

impl Reference {
    pub fn new(model: std::sync::Arc<Model>) -> Self {
        let x = model.initial.x.iter().map(|p| p.as_dvec3()).collect();
        let v = model.initial.v.iter().map(|p| p.as_dvec3()).collect();
        Self {
            model,
            x,
            v,
            time_secs: 0.0,
        }
    }

    /// Accelerations at (x, v, t). `dt` bounds friction's stick as the backends do, with the
    /// reference's own step: sticking then happens within a reference step, which is Coulomb
    /// friction as the step goes to zero. (Bounding it with a judged run's coarser step instead
    /// would turn sticking into a viscous drag of time constant dt, a different law: on jello that
    /// moved the reference by 11 cm at dt = 1/1200 s.)
    fn acceleration(&self, x: &[DVec3], v: &[DVec3], t: f64, dt: f64) -> Vec<DVec3> {
        let m = &*self.model;
        let poses: Vec<(DVec3, DVec3)> = m
            .effects
            .colliders
            .iter()
            .map(|c| c.path.pose_at_f64(t))
            .collect();
        let grid = m.effects.self_collision.map(|c| {
            let mut g = MassGrid::new(x.len(), c.radius_m);
            g.build_f64(x);
            (c, g)
        });
        let mut f = spring_forces(m, x, v);
        let one = |(i, f): (usize, &mut DVec3)| {
            if m.inv_mass[i] == 0.0 {
                *f = DVec3::ZERO;
                return;
            }
            *f = force_on_mass(m, &poses, x, v, i, dt, *f);
            if let Some((c, g)) = &grid {
                *f += pair_contacts(m, c, g, x, v, i, dt);
            }
            *f /= f64::from(m.mass_kg[i]);
        };
        if x.len() >= PARALLEL_MIN_MASSES {
            f.par_iter_mut().enumerate().for_each(one);
        } else {
            f.iter_mut().enumerate().for_each(one);
        }
        f
    }

    /// Advance to `until` with RK4 steps of at most `h` (the last one shortened to land on it).
    pub fn advance_to(&mut self, until: f64, h: f64) {
        self.advance_to_unless(until, h, &std::sync::atomic::AtomicBool::new(false));
    }

    /// [`Self::advance_to`], stopping between steps once `cancel` is set: `false` when it did
    /// (a long reference is interruptible like any run).
    pub fn advance_to_unless(
        &mut self,
        until: f64,
        h: f64,
        cancel: &std::sync::atomic::AtomicBool,
    ) -> bool {
        let stick_dt = h;
        while self.time_secs < until - 1e-12 {
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return false;
            }
            let h = h.min(until - self.time_secs);
            let t = self.time_secs;
            let (x, v) = (&self.x, &self.v);
            let axpy = |a: &[DVec3], s: f64, b: &[DVec3]| {
                a.iter()
                    .zip(b)
                    .map(|(p, q)| *p + s * *q)
                    .collect::<Vec<_>>()
            };
            let a1 = self.acceleration(x, v, t, stick_dt);
            let (x2, v2) = (axpy(x, 0.5 * h, v), axpy(v, 0.5 * h, &a1));
            let a2 = self.acceleration(&x2, &v2, t + 0.5 * h, stick_dt);
            let (x3, v3) = (axpy(x, 0.5 * h, &v2), axpy(v, 0.5 * h, &a2));
            let a3 = self.acceleration(&x3, &v3, t + 0.5 * h, stick_dt);
            let (x4, v4) = (axpy(x, h, &v3), axpy(v, h, &a3));
            let a4 = self.acceleration(&x4, &v4, t + h, stick_dt);
            let x_next: Vec<DVec3> = (0..x.len())
                .map(|i| x[i] + h / 6.0 * (v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]))
                .collect();
            let v_next: Vec<DVec3> = (0..x.len())
                .map(|i| v[i] + h / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]))
                .collect();
            self.x = x_next;
            self.v = v_next;
            self.time_secs += h;
        }
        true
    }
}

/// Springs in this many parts, each summed into its own buffer and the buffers added in order:
/// the same sums whatever the thread count (determinism), at most this many copies of the force.
const SPRING_PARTS: usize = 8;

/// Below this many springs the parts are summed on this thread: the pool's start-up per force
/// evaluation would cost more than the sums.
const PARALLEL_MIN_SPRINGS: usize = 4096;

/// The spring forces on every mass. Springs once each, both ends at a time: half the work of
/// gathering per mass (the accuracy benchmark spends much of its time here).
fn spring_forces(m: &Model, x: &[DVec3], v: &[DVec3]) -> Vec<DVec3> {
    let part = m.springs.len().div_ceil(SPRING_PARTS).max(1);
    let sum_part = |springs: &[crate::model::Spring]| {
        let mut f = vec![DVec3::ZERO; x.len()];
        for s in springs {
            let (a, b) = (s.a as usize, s.b as usize);
            let fa = spring_force::<f64>(s, x[a], x[b], v[a], v[b]).0;
            f[a] += fa;
            f[b] -= fa;
        }
        f
    };
    // The same parts either way, so the same sums: threads only where they pay.
    let parts: Vec<Vec<DVec3>> = if m.springs.len() >= PARALLEL_MIN_SPRINGS {
        m.springs.par_chunks(part).map(sum_part).collect()
    } else {
        m.springs.chunks(part).map(sum_part).collect()
    };
    let mut parts = parts.into_iter();
    let mut f = parts.next().unwrap_or_else(|| vec![DVec3::ZERO; x.len()]);
    for p in parts {
        for (f, p) in f.iter_mut().zip(p) {
            *f += p;
        }
    }
    f
}

/// The force on mass `i`: `springs` (its springs' force, summed apart) plus gravity, drag, the
/// ground and the colliders (at `poses`, each a position and velocity), in the backends' order:
/// each contact's friction holds against the forces before it.
fn force_on_mass(
    m: &Model,
    poses: &[(DVec3, DVec3)],
    x: &[DVec3],
    v: &[DVec3],
    i: usize,
    dt: f64,
    springs: DVec3,
) -> DVec3 {
    let fx = &m.effects;
    let (xi, vi, mass) = (x[i], v[i], f64::from(m.mass_kg[i]));
    let mut f = springs;
    if let Some(g) = fx.gravity_m_per_s2 {
        f += mass * g.as_dvec3();
    }
    if let Some(gamma) = fx.air_drag_per_s {
        f -= mass * f64::from(gamma) * vi;
    }
    if let Some(g) = &fx.ground {
        let depth = f64::from(g.height_m) - xi.y;
        if depth > 0.0 {
            f += contact_force(&g.contact, depth, DVec3::Y, (vi, f), mass, dt, 1.0).0;
        }
    }
    for (c, (center, u)) in fx.colliders.iter().zip(poses) {
        if let Some((depth, n)) = c.shape.penetration(*center, xi) {
            f += contact_force(&c.contact, depth, n, (vi - *u, f), mass, dt, 1.0).0;
        }
    }
    f
}

/// The mass–mass contact force on mass `i`, over its candidates in `grid` (built from `x`).
fn pair_contacts(
    m: &Model,
    c: &MassContact,
    grid: &MassGrid,
    x: &[DVec3],
    v: &[DVec3],
    i: usize,
    dt: f64,
) -> DVec3 {
    let (xi, mass) = (x[i], f64::from(m.mass_kg[i]));
    let diameter = 2.0 * f64::from(c.radius_m);
    let cell = (xi * f64::from(grid.inv_cell_per_m())).floor().as_ivec3();
    let mut f = DVec3::ZERO;
    grid.for_each_candidate(cell, |j| {
        if j == i || !(c.within_bodies || m.mass_body[i] != m.mass_body[j]) {
            return;
        }
        let d = xi - x[j];
        let dist = d.length();
        if dist >= diameter || dist == 0.0 {
            return;
        }
        // The pair's reduced mass (a pinned partner weighs infinitely much).
        let mu = 1.0 / (1.0 / mass + f64::from(m.inv_mass[j]));
        let stick = f64::from(PAIR_STICK_SHARE);
        f += contact_force(
            &c.contact,
            diameter - dist,
            d / dist,
            (v[i] - v[j], DVec3::ZERO),
            mu,
            dt,
            stick,
        )
        .0;
    });
    f
}
