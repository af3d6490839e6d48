//! `compute_forces`: the full force on every mass (springs, gravity, drag, contact), gathered per
//! mass through the CSR adjacency. Mirrors `compute_forces` in `shaders/forces.wgsl`; mass–mass
//! contact is added after it by `collide_masses`, as the GPU adds it in a pass of its own.

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use super::collide_masses::collide_masses;
use super::law::{contact_acts, contact_force, contact_normal_force, spring_force};
use super::neighbours::Neighbours;
use crate::model::{Model, Pose, Spring, poses_at};
use crate::state::Power;

/// Force on mass `i` and its contributions to the ledger's rates; without the springs' force
/// when `SPRINGS` is false (XPBD projects them as constraints instead), but with their dashpots'
/// power, which the ledger books either way.
#[inline(always)]
pub(super) fn force_on_mass<const SPRINGS: bool>(
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
        let (fs, pw) = spring_force::<f32>(&e.spring, xi, x[j], vi, v[j]);
        if SPRINGS {
            f += fs;
        }
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
        let pushes = contact_normal_force(&g.contact, depth, vi.y, m);
        if contact_acts(pushes, depth) {
            let (fc, diss) = contact_force(&g.contact, depth, Vec3::Y, (vi, f), m, dt, 1.0);
            f += fc;
            contact_w += diss;
        }
    }
    for (c, pose) in e.colliders.iter().zip(poses) {
        if let Some((depth, n)) = c.shape.signed_depth(pose.position_m, xi) {
            let u = pose.velocity_m_per_s;
            let pushes = contact_normal_force(&c.contact, depth, (vi - u).dot(n), m);
            if contact_acts(pushes, depth) {
                let (fc, diss) = contact_force(&c.contact, depth, n, (vi - u, f), m, dt, 1.0);
                f += fc;
                contact_w += diss;
                collider_w += fc.dot(u);
            }
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
/// the neighbour lists, which a force evaluation rebuilds only when they have gone stale.
#[derive(Debug, Default)]
pub struct Gather {
    offsets: Vec<u32>,
    entries: Vec<GatherEntry>,
    springs: Vec<Spring>,
    /// The two entries of each spring; only when springs change during the run.
    entries_of: Vec<[u32; 2]>,
    neighbours: Option<Neighbours>,
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
            neighbours: model
                .effects
                .self_collision
                .map(|c| Neighbours::new(model.mass_count(), &c)),
        }
    }

    /// The springs as they are now.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }

    /// How many times the neighbour lists have been built; `None` without mass–mass contact.
    pub fn neighbour_builds(&self) -> Option<u64> {
        self.neighbours.as_ref().map(Neighbours::builds)
    }

    /// Mass `i`'s springs as they are now, each with the mass at its other end.
    pub(super) fn springs_of(&self, i: usize) -> impl Iterator<Item = (usize, &Spring)> {
        self.entries[self.offsets[i] as usize..self.offsets[i + 1] as usize]
            .iter()
            .map(|e| (e.other as usize, &e.spring))
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
    forces::<true>(model, gather, x, v, t, dt, acc)
}

/// [`compute_forces`] less the springs' force: what XPBD integrates before it projects them.
/// The rates still hold the dashpots' power at (x, v), which XPBD books as its damping. The GPU
/// runs `compute_forces` compiled with `XPBD` for it.
pub fn compute_external_forces(
    model: &Model,
    gather: &mut Gather,
    x: &[Vec3],
    v: &[Vec3],
    t: f64,
    dt: f32,
    acc: &mut [Vec3],
) -> Power {
    forces::<false>(model, gather, x, v, t, dt, acc)
}

fn forces<const SPRINGS: bool>(
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
            let (ai, p) =
                force_on_mass::<SPRINGS>(model, springs, &poses, x, v, ci * CHUNK + k, dt);
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
    if let (Some(c), Some(nb)) = (&model.effects.self_collision, gather.neighbours.as_mut()) {
        nb.update(model, c, x);
        contact_w += collide_masses(model, c, nb, x, v, dt, acc);
    }
    Power {
        damping_w: total[0],
        drag_w: total[1],
        contact_w,
        collider_w: total[3],
    }
}
