//! `compute_forces`: the full force on every mass (springs, gravity, drag, contact), gathered per
//! mass through the CSR adjacency. Mirrors `compute_forces` in `shaders/forces.wgsl`; mass–mass
//! contact is added after it by `collide_masses`, as the GPU adds it in a pass of its own.

use glam::Vec3;
use rayon::prelude::*;

use super::collide_masses::collide_masses;
use super::grid::MassGrid;
use crate::model::{ContactModel, Model, Pose, Spring, poses_at};
use crate::state::Power;

/// Masses per work item. Fixed, so that the per-chunk partial sums (and hence the energy ledger)
/// are bit-identical whatever the thread count.
pub const CHUNK: usize = 1024;

/// Below this many masses the thread pool costs more than it saves.
pub const PARALLEL_MIN_MASSES: usize = 4 * CHUNK;

/// Force exerted on mass `i` by spring `s` whose other end is `j`: elastic plus damping along the
/// spring, and the damping part's power at `i`. A zero-length spring has no direction and exerts
/// nothing (no division by zero).
#[inline(always)]
pub fn spring_force(s: &Spring, xi: Vec3, xj: Vec3, vi: Vec3, vj: Vec3) -> (Vec3, f32) {
    let d = xi - xj;
    let len = d.length();
    if len <= f32::MIN_POSITIVE * 1e6 {
        return (Vec3::ZERO, 0.0);
    }
    // One division, not three: the same on the GPU (forces.wgsl), so the two stay identical.
    let n = d * (1.0 / len);
    let elastic = -s.stiffness_n_per_m * (len - s.rest_m);
    let damping = -s.damping_n_s_per_m * (vi - vj).dot(n);
    (n * (elastic + damping), damping * n.dot(vi))
}

/// Penalty contact along unit normal `n` at depth `depth` > 0, for a mass with velocity `v_rel`
/// relative to the collider. Returns the force and the power dissipated by its damping and
/// friction parts (≥ 0). Friction is Coulomb, `|F_t| ≤ μ F_n`, and stops at most `stick_share`
/// of the sliding within one step (1 for a collider: it cannot reverse the motion; less for
/// mass pairs, several of which may act on one mass, see `PAIR_STICK_SHARE`).
#[inline(always)]
pub fn contact_force(
    c: &ContactModel,
    depth: f32,
    n: Vec3,
    v_rel: Vec3,
    mass: f32,
    dt: f32,
    stick_share: f32,
) -> (Vec3, f32) {
    let vn = v_rel.dot(n);
    let spring = c.stiffness_n_per_m * depth;
    let damper = -2.0 * c.damping_ratio * (c.stiffness_n_per_m * mass).sqrt() * vn;
    // Contact pushes, never pulls: the damper may at most cancel the spring.
    let fn_total = (spring + damper).max(0.0);
    let damper_part = fn_total - spring;
    let mut force = n * fn_total;
    let mut dissipated = -damper_part * vn;
    if c.friction > 0.0 {
        let vt = v_rel - vn * n;
        let speed = vt.length();
        if speed > 0.0 {
            let ft = (c.friction * fn_total).min(stick_share * mass * speed / dt);
            force -= vt * (ft / speed);
            dissipated += ft * speed;
        }
    }
    (force, dissipated)
}

/// Force on mass `i` and its contributions to the ledger's rates.
#[inline(always)]
fn force_on_mass(
    model: &Model,
    gather: &Gather,
    poses: &[Pose],
    x: &[Vec3],
    v: &[Vec3],
    i: usize,
    dt: f32,
) -> (Vec3, [f32; 4]) {
    let xi = x[i];
    let vi = v[i];
    let m = model.mass_kg[i];
    let mut f = Vec3::ZERO;
    let mut damping_w = 0.0f32;
    let tearing = model.effects.tearing;
    for e in &gather.entries[gather.offsets[i] as usize..gather.offsets[i + 1] as usize] {
        // A broken spring exerts nothing; skipping it saves reading the other end.
        if tearing && e.spring.is_broken() {
            continue;
        }
        let j = e.other as usize;
        let (fs, pw) = spring_force(&e.spring, xi, x[j], vi, v[j]);
        f += fs;
        damping_w += pw;
    }
    let e = &model.effects;
    if let Some(g) = e.gravity_m_per_s2 {
        f += m * g;
    }
    let mut drag_w = 0.0;
    if let Some(gamma) = e.air_drag_per_s {
        let fd = -m * gamma * vi;
        f += fd;
        drag_w = fd.dot(vi);
    }
    let mut contact_w = 0.0;
    let mut collider_w = 0.0;
    if let Some(g) = &e.ground {
        let depth = g.height_m - xi.y;
        if depth > 0.0 {
            let (fc, diss) = contact_force(&g.contact, depth, Vec3::Y, vi, m, dt, 1.0);
            f += fc;
            contact_w += diss;
        }
    }
    for (c, pose) in e.colliders.iter().zip(poses) {
        if let Some((depth, n)) = c.shape.penetration(pose.position_m, xi) {
            let u = pose.velocity_m_per_s;
            let (fc, diss) = contact_force(&c.contact, depth, n, vi - u, m, dt, 1.0);
            f += fc;
            contact_w += diss;
            collider_w += fc.dot(u);
        }
    }
    // Ledger rates are energy leaving the system (damping, drag, contact) and entering it
    // (collider work); a pinned mass does not move, so nothing flows through it.
    if model.inv_mass[i] == 0.0 {
        return (Vec3::ZERO, [0.0; 4]);
    }
    (
        f * model.inv_mass[i],
        [-damping_w, -drag_w, contact_w, collider_w],
    )
}

/// The CSR adjacency with each spring's parameters stored in the entry itself, in the same order
/// as `model.adjacency`: the gather streams through one array instead of chasing a spring index
/// per neighbour. (The GPU reads springs by index; its caches make that cheap.) It also holds the
/// live springs, which plasticity and tearing change during a run, and with mass–mass contact
/// the hash grid that each force evaluation rebuilds.
#[derive(Debug, Default)]
pub struct Gather {
    offsets: Vec<u32>,
    entries: Vec<GatherEntry>,
    springs: Vec<Spring>,
    /// The two entries of each spring; only when springs change during the run.
    entries_of: Vec<[u32; 2]>,
    mass_grid: Option<MassGrid>,
}

#[derive(Debug, Clone, Copy)]
struct GatherEntry {
    other: u32,
    spring: Spring,
}

impl Gather {
    pub fn new(model: &Model) -> Self {
        let mut entries_of = Vec::new();
        if model.effects.springs_change() {
            entries_of = vec![[0u32; 2]; model.spring_count()];
            let mut seen = vec![0u8; model.spring_count()];
            for (e, nb) in model.adjacency.entries.iter().enumerate() {
                let k = nb.spring as usize;
                entries_of[k][usize::from(seen[k])] = e as u32;
                seen[k] += 1;
            }
        }
        Self {
            offsets: model.adjacency.offsets.clone(),
            entries: model
                .adjacency
                .entries
                .iter()
                .map(|nb| GatherEntry {
                    other: nb.other,
                    spring: model.springs[nb.spring as usize],
                })
                .collect(),
            springs: model.springs.clone(),
            entries_of,
            mass_grid: model
                .effects
                .self_collision
                .map(|c| MassGrid::new(model.mass_count(), c.radius_m)),
        }
    }

    /// The springs as they are now.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }

    /// Replace spring `k` (a new rest length, or broken) everywhere the force pass reads it.
    pub fn set_spring(&mut self, k: usize, spring: Spring) {
        self.springs[k] = spring;
        for e in self.entries_of[k] {
            self.entries[e as usize].spring = spring;
        }
    }
}

/// Accelerations of every mass at state (x, v, t) into `acc`; returns the ledger rates.
pub fn compute_forces(
    model: &Model,
    gather: &mut Gather,
    x: &[Vec3],
    v: &[Vec3],
    t: f64,
    dt: f32,
    acc: &mut [Vec3],
) -> Power {
    let poses = poses_at(&model.effects.colliders, t);
    let springs = &*gather;
    let chunk_sum = |(ci, out): (usize, &mut [Vec3])| -> [f64; 4] {
        let mut sum = [0.0f64; 4];
        for (k, a) in out.iter_mut().enumerate() {
            let (ai, p) = force_on_mass(model, springs, &poses, x, v, ci * CHUNK + k, dt);
            *a = ai;
            for (s, q) in sum.iter_mut().zip(p) {
                *s += f64::from(q);
            }
        }
        sum
    };
    // Per-chunk sums added in chunk order either way, so threads change nothing in the result.
    let add = |mut total: [f64; 4], p: [f64; 4]| {
        for (t, q) in total.iter_mut().zip(p) {
            *t += q;
        }
        total
    };
    let total = if acc.len() >= PARALLEL_MIN_MASSES {
        let partials: Vec<[f64; 4]> = acc
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(chunk_sum)
            .collect();
        partials.into_iter().fold([0.0; 4], add)
    } else {
        acc.chunks_mut(CHUNK)
            .enumerate()
            .map(chunk_sum)
            .fold([0.0; 4], add)
    };
    let mut contact_w = total[2];
    if let (Some(c), Some(grid)) = (&model.effects.self_collision, gather.mass_grid.as_mut()) {
        // The grid of the positions this evaluation reads, as the GPU builds it.
        grid.build(x);
        contact_w += collide_masses(model, c, grid, x, v, dt, acc);
    }
    Power {
        damping_w: total[0],
        drag_w: total[1],
        contact_w,
        collider_w: total[3],
    }
}
