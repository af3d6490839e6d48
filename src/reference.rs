//! The f64 reference solution the accuracy benchmark measures against: the model's full force
//! (springs, gravity, drag, contact with friction, mass–mass contact) evaluated in double precision and integrated
//! by classic RK4 at a step much finer than any it judges. Same formulas as `cpu::forces`
//! (`compute_forces`), so what differs is only precision and step size.

use glam::DVec3;
use rayon::prelude::*;

use crate::model::{ContactModel, Model};

pub struct Reference {
    model: std::sync::Arc<Model>,
    pub x: Vec<DVec3>,
    pub v: Vec<DVec3>,
    pub time_secs: f64,
}

/// `stick_share`: the share of the sliding friction may stop in one step (1 for colliders,
/// `PAIR_STICK_SHARE` between masses).
fn contact_force_f64(
    c: &ContactModel,
    depth: f64,
    n: DVec3,
    v_rel: DVec3,
    mass: f64,
    dt: f64,
    stick_share: f64,
) -> DVec3 {
    let k = f64::from(c.stiffness_n_per_m);
    let vn = v_rel.dot(n);
    let fn_total = (k * depth - 2.0 * f64::from(c.damping_ratio) * (k * mass).sqrt() * vn).max(0.0);
    let mut f = n * fn_total;
    let vt = v_rel - vn * n;
    let speed = vt.length();
    if c.friction > 0.0 && speed > 0.0 {
        f -= vt * ((f64::from(c.friction) * fn_total).min(stick_share * mass * speed / dt) / speed);
    }
    f
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

    /// Accelerations at (x, v, t). `dt` bounds friction as the backends do, with the step the
    /// reference is judged against, not its own.
    fn acceleration(&self, x: &[DVec3], v: &[DVec3], t: f64, dt: f64) -> Vec<DVec3> {
        let m = &*self.model;
        let fx = &m.effects;
        let poses: Vec<(DVec3, DVec3)> =
            fx.colliders.iter().map(|c| c.path.pose_at_f64(t)).collect();
        let grid = fx.self_collision.map(|c| {
            let mut g = crate::cpu::MassGrid::new(x.len(), c.radius_m);
            g.build_f64(x);
            (c, g)
        });
        let one = |i: usize| {
            if m.inv_mass[i] == 0.0 {
                return DVec3::ZERO;
            }
            let (xi, vi, mass) = (x[i], v[i], f64::from(m.mass_kg[i]));
            let mut f = DVec3::ZERO;
            for nb in m.adjacency.of(i) {
                let s = &m.springs[nb.spring as usize];
                let j = nb.other as usize;
                let d = xi - x[j];
                let len = d.length();
                if len > 1e-30 {
                    let n = d / len;
                    let elastic = -f64::from(s.stiffness_n_per_m) * (len - f64::from(s.rest_m));
                    let damping = -f64::from(s.damping_n_s_per_m) * (vi - v[j]).dot(n);
                    f += n * (elastic + damping);
                }
            }
            if let Some(g) = fx.gravity_m_per_s2 {
                f += mass * g.as_dvec3();
            }
            if let Some(gamma) = fx.air_drag_per_s {
                f -= mass * f64::from(gamma) * vi;
            }
            if let Some(g) = &fx.ground {
                let depth = f64::from(g.height_m) - xi.y;
                if depth > 0.0 {
                    f += contact_force_f64(&g.contact, depth, DVec3::Y, vi, mass, dt, 1.0);
                }
            }
            for (c, (center, u)) in fx.colliders.iter().zip(&poses) {
                if let Some((depth, n)) = c.shape.penetration_f64(*center, xi) {
                    f += contact_force_f64(&c.contact, depth, n, vi - *u, mass, dt, 1.0);
                }
            }
            if let Some((c, g)) = &grid {
                let diameter = 2.0 * f64::from(c.radius_m);
                let cell = (xi * f64::from(g.inv_cell_per_m())).floor().as_ivec3();
                g.for_each_candidate(cell, |j| {
                    if j == i || !(c.within_bodies || m.mass_body[i] != m.mass_body[j]) {
                        return;
                    }
                    let d = xi - x[j];
                    let dist = d.length();
                    if dist >= diameter || dist == 0.0 {
                        return;
                    }
                    // The pair's reduced mass (a pinned partner weighs infinitely much).
                    let wj = f64::from(m.inv_mass[j]);
                    let mu = 1.0 / (1.0 / mass + wj);
                    f += contact_force_f64(
                        &c.contact,
                        diameter - dist,
                        d / dist,
                        vi - v[j],
                        mu,
                        dt,
                        f64::from(crate::cpu::PAIR_STICK_SHARE),
                    );
                });
            }
            f / mass
        };
        if x.len() >= crate::cpu::PARALLEL_MIN_MASSES {
            (0..x.len()).into_par_iter().map(one).collect()
        } else {
            (0..x.len()).map(one).collect()
        }
    }

    /// Advance to `until` with RK4 steps of at most `h` (the last one shortened to land on it).
    /// `judged_dt` is the step of the runs being judged (it scales friction's stick limit).
    pub fn advance_to(&mut self, until: f64, h: f64, judged_dt: f64) {
        while self.time_secs < until - 1e-12 {
            let h = h.min(until - self.time_secs);
            let t = self.time_secs;
            let (x, v) = (&self.x, &self.v);
            let axpy = |a: &[DVec3], s: f64, b: &[DVec3]| {
                a.iter()
                    .zip(b)
                    .map(|(p, q)| *p + s * *q)
                    .collect::<Vec<_>>()
            };
            let a1 = self.acceleration(x, v, t, judged_dt);
            let (x2, v2) = (axpy(x, 0.5 * h, v), axpy(v, 0.5 * h, &a1));
            let a2 = self.acceleration(&x2, &v2, t + 0.5 * h, judged_dt);
            let (x3, v3) = (axpy(x, 0.5 * h, &v2), axpy(v, 0.5 * h, &a2));
            let a3 = self.acceleration(&x3, &v3, t + 0.5 * h, judged_dt);
            let (x4, v4) = (axpy(x, h, &v3), axpy(v, h, &a3));
            let a4 = self.acceleration(&x4, &v4, t + h, judged_dt);
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
    }
}
