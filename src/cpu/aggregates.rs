//! The aggregates of implicit Euler's multigrid preconditioner (`multigrid.rs`): which nodes make
//! each coarse node and which edges each coarse edge (built once per model), and each level's
//! products at the current linearisation.

use std::collections::HashMap;

use glam::{IVec3, Mat3, Vec3};

use super::chunks::each_mass as each;
use super::system_blocks::invert_block;
use crate::model::{BodyShape, Model};

/// A pinned mass's aggregate: none.
pub(super) const NONE: u32 = u32::MAX;

/// Where a finer edge's block goes on the next level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fate {
    /// Into a coarse edge.
    Edge(u32),
    /// Into a coarse node's own block (a spring from a free mass to a pinned one).
    Own(u32),
    /// Nowhere: both ends are in one aggregate (Pᵀ A P cancels it), or both are pinned.
    Dropped,
}

/// Compressed rows: `entries[offsets[i]..offsets[i + 1]]` belong to row i.
#[derive(Debug, Clone, Default)]
pub(super) struct Rows<T> {
    pub(super) offsets: Vec<u32>,
    pub(super) entries: Vec<T>,
}

impl<T: Copy> Rows<T> {
    fn build(rows: usize, items: impl Iterator<Item = (usize, T)> + Clone) -> Self {
        let mut offsets = vec![0u32; rows + 1];
        for (r, _) in items.clone() {
            offsets[r + 1] += 1;
        }
        for r in 0..rows {
            offsets[r + 1] += offsets[r];
        }
        let mut fill = offsets.clone();
        let mut entries = Vec::with_capacity(offsets[rows] as usize);
        // Filled in the items' order within each row.
        let mut slots: Vec<Option<T>> = vec![None; offsets[rows] as usize];
        for (r, t) in items {
            slots[fill[r] as usize] = Some(t);
            fill[r] += 1;
        }
        entries.extend(slots.into_iter().flatten());
        Self { offsets, entries }
    }

    pub(super) fn of(&self, r: usize) -> &[T] {
        &self.entries[self.offsets[r] as usize..self.offsets[r + 1] as usize]
    }
}

/// One coarse level's topology: built once per model.
#[derive(Debug, Clone)]
pub(super) struct Level {
    pub(super) nodes: usize,
    /// Each finer node's aggregate here (NONE for a pinned mass).
    pub(super) parent: Vec<u32>,
    /// Each node's members on the finer level, in order.
    pub(super) members: Rows<u32>,
    /// This level's edges (a < b).
    pub(super) edges: Vec<[u32; 2]>,
    /// Each edge's finer edges; each node's finer edges to pinned masses.
    pub(super) edge_sources: Rows<u32>,
    pub(super) own_sources: Rows<u32>,
    /// Each node's edges and the node at their other end.
    pub(super) incident: Rows<(u32, u32)>,
    /// Each node's body and lattice cell (its members' cells halved).
    pub(super) cells: Vec<(u32, IVec3)>,
}

/// One coarse level's numbers at the current linearisation.
#[derive(Debug, Clone, Default)]
pub(super) struct Values {
    pub(super) own: Vec<Mat3>,
    pub(super) edge: Vec<Mat3>,
    pub(super) diag_inv: Vec<Mat3>,
    pub(super) x: Vec<Vec3>,
    pub(super) b: Vec<Vec3>,
    pub(super) r: Vec<Vec3>,
}

/// Each free mass's lattice cell on the finest level (None for a pinned one).
pub(super) fn mass_cells(model: &Model) -> Vec<Option<(u32, IVec3)>> {
    let mut cells = vec![None; model.mass_count()];
    for (bi, body) in model.bodies.iter().enumerate() {
        let range = body.masses.start as usize..body.masses.end as usize;
        match &body.shape {
            BodyShape::Grid(dims) => {
                let nx = dims.first().copied().unwrap_or(1).max(1);
                let ny = dims.get(1).copied().unwrap_or(1).max(1);
                for (local, i) in range.enumerate() {
                    let l = local as u32;
                    let q = IVec3::new(
                        (l % nx) as i32,
                        (l / nx % ny) as i32,
                        (l / (nx * ny)) as i32,
                    );
                    cells[i] = Some((bi as u32, q));
                }
            }
            BodyShape::Mesh(_) => {
                let springs =
                    &model.springs[body.springs.start as usize..body.springs.end as usize];
                let mean = springs.iter().map(|s| f64::from(s.rest_m)).sum::<f64>()
                    / springs.len().max(1) as f64;
                let x = &model.initial.x[range.clone()];
                let low = x.iter().fold(Vec3::splat(f32::INFINITY), |a, b| a.min(*b));
                let width = mean.max(1e-9) as f32;
                for (k, i) in range.enumerate() {
                    let q = ((x[k] - low) / width).floor();
                    cells[i] = Some((bi as u32, q.as_ivec3()));
                }
            }
        }
    }
    for (i, c) in cells.iter_mut().enumerate() {
        if model.inv_mass[i] == 0.0 {
            *c = None;
        }
    }
    cells
}

/// The next level from a finer one's node cells (None: pinned) and edges.
pub(super) fn coarsen(fine: &[Option<(u32, IVec3)>], fine_edges: &[[u32; 2]]) -> Level {
    let mut ids: HashMap<(u32, IVec3), u32> = HashMap::new();
    let mut cells = Vec::new();
    let parent: Vec<u32> = fine
        .iter()
        .map(|c| match c {
            None => NONE,
            Some((body, q)) => {
                let key = (*body, IVec3::new(q.x >> 1, q.y >> 1, q.z >> 1));
                *ids.entry(key).or_insert_with(|| {
                    cells.push(key);
                    (cells.len() - 1) as u32
                })
            }
        })
        .collect();
    let nodes = cells.len();
    let members = Rows::build(
        nodes,
        parent
            .iter()
            .enumerate()
            .filter(|(_, p)| **p != NONE)
            .map(|(i, p)| (*p as usize, i as u32)),
    );
    let mut edge_ids: HashMap<(u32, u32), u32> = HashMap::new();
    let mut edges = Vec::new();
    let fates: Vec<Fate> = fine_edges
        .iter()
        .map(|&[a, b]| {
            let (pa, pb) = (parent[a as usize], parent[b as usize]);
            match (pa, pb) {
                (NONE, NONE) => Fate::Dropped,
                (p, NONE) | (NONE, p) => Fate::Own(p),
                (p, q) if p == q => Fate::Dropped,
                (p, q) => {
                    let key = (p.min(q), p.max(q));
                    Fate::Edge(*edge_ids.entry(key).or_insert_with(|| {
                        edges.push([key.0, key.1]);
                        (edges.len() - 1) as u32
                    }))
                }
            }
        })
        .collect();
    let edge_sources = Rows::build(
        edges.len(),
        fates.iter().enumerate().filter_map(|(f, fate)| match fate {
            Fate::Edge(e) => Some((*e as usize, f as u32)),
            _ => None,
        }),
    );
    let own_sources = Rows::build(
        nodes,
        fates.iter().enumerate().filter_map(|(f, fate)| match fate {
            Fate::Own(n) => Some((*n as usize, f as u32)),
            _ => None,
        }),
    );
    let incident = Rows::build(
        nodes,
        edges
            .iter()
            .enumerate()
            .flat_map(|(e, &[a, b])| [(a as usize, (e as u32, b)), (b as usize, (e as u32, a))]),
    );
    Level {
        nodes,
        parent,
        members,
        edges,
        edge_sources,
        own_sources,
        incident,
        cells,
    }
}

impl Level {
    /// Its blocks from the finer level's: `fine_own(m)`, each finer node's own block, and
    /// `fine_edge(f)`, each finer edge's.
    pub(super) fn linearise(
        &self,
        v: &mut Values,
        fine_own: impl Fn(usize) -> Mat3 + Sync,
        fine_edge: impl Fn(usize) -> Mat3 + Sync,
    ) {
        each(&mut v.edge, |e, out| {
            *out = self
                .edge_sources
                .of(e)
                .iter()
                .fold(Mat3::ZERO, |acc, &f| acc + fine_edge(f as usize));
        });
        each(&mut v.own, |n, out| {
            let own = self
                .members
                .of(n)
                .iter()
                .fold(Mat3::ZERO, |acc, &m| acc + fine_own(m as usize));
            *out = self
                .own_sources
                .of(n)
                .iter()
                .fold(own, |acc, &f| acc + fine_edge(f as usize));
        });
        let (own, edge) = (&v.own, &v.edge);
        each(&mut v.diag_inv, |n, out| {
            let diag = self
                .incident
                .of(n)
                .iter()
                .fold(own[n], |acc, &(e, _)| acc + edge[e as usize]);
            *out = invert_block(diag);
        });
    }

    /// y = A x on this level: each node's own block, and each edge's block on the difference
    /// across it.
    pub(super) fn apply(&self, (own, edge): (&[Mat3], &[Mat3]), x: &[Vec3], y: &mut [Vec3]) {
        each(y, |n, out| {
            *out = self
                .incident
                .of(n)
                .iter()
                .fold(own[n] * x[n], |acc, &(e, o)| {
                    acc + edge[e as usize] * (x[n] - x[o as usize])
                });
        });
    }

    /// The coarse right-hand side from a finer residual: the sum over each node's members.
    pub(super) fn restrict(&self, fine: &[Vec3], coarse: &mut [Vec3]) {
        each(coarse, |n, out| {
            *out = self
                .members
                .of(n)
                .iter()
                .fold(Vec3::ZERO, |acc, &m| acc + fine[m as usize]);
        });
    }

    /// x += P x_c: each finer node takes its aggregate's correction.
    pub(super) fn prolong(&self, coarse: &[Vec3], fine: &mut [Vec3]) {
        let parent = &self.parent;
        each(fine, |m, out| {
            if parent[m] != NONE {
                *out += coarse[parent[m] as usize];
            }
        });
    }
}
