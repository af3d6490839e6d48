//! The coarse levels of implicit Euler's aggregation multigrid, built once per model and shared
//! by both backends (`cpu/multigrid.rs` runs the cycle on the CPU, `gpu/multigrid.rs` uploads the
//! levels for `shaders/multigrid.wgsl`): which nodes make each coarse node, which finer edges
//! make each coarse edge, and each level's edges.
//!
//! - A level's nodes are blocks of two along each axis of the level above (2 × 2 on a sheet,
//!   2 × 2 × 2 in a block): a grid body by its grid indices, a mesh body by cells of its rest
//!   positions twice its springs' mean rest length wide. Pinned masses belong to none.
//! - Coarsening stops at `COARSEST_NODES` nodes, or when a level would not halve.

use std::collections::HashMap;

use glam::{IVec3, Vec3};

use crate::model::{BodyShape, Model};

/// The coarsest level's most nodes: its dense system (3 unknowns a node) is solved directly, on
/// the CPU by a Cholesky factor in f64, on the GPU by an inverse in one workgroup (48 × 48 f32
/// in 9 KiB of workgroup memory). 96 nodes took fewer CG iterations on the CPU than 16 but cost
/// more below 65 536 masses (its factor is 27 times the work), and gained only on the 256 × 256
/// peer cloth (BENCHMARKS.md, "Multigrid on the GPU").
pub const COARSEST_NODES: usize = 16;

/// Block Jacobi's damping in the cycle's sweeps (both backends; `MG_SMOOTHING` in WGSL): the
/// blocks' row sums bound D⁻¹A's eigenvalues by 2, so 2/3 damps the sheet's shortest waves (λ
/// near 2) by a third and never amplifies one.
pub const SMOOTHING: f32 = 2.0 / 3.0;

/// A pinned mass's aggregate: none.
pub const NONE: u32 = u32::MAX;

/// Every coarse level of a model, finest first.
#[derive(Debug, Clone)]
pub struct Hierarchy {
    pub levels: Vec<Level>,
}

impl Hierarchy {
    /// The levels for `model`, or None when it would have no coarse level.
    pub fn new(model: &Model) -> Option<Self> {
        let mut levels = Vec::new();
        // The finer level: its nodes' cells (and bodies), its edges.
        let mut fine: Vec<Option<(u32, IVec3)>> = mass_cells(model);
        let mut fine_edges: Vec<[u32; 2]> = model.springs.iter().map(|s| [s.a, s.b]).collect();
        let mut fine_nodes = model.mass_count();
        loop {
            let level = coarsen(&fine, &fine_edges);
            if level.nodes == 0 || 2 * level.nodes > fine_nodes + 1 {
                break;
            }
            fine = level.cells.iter().map(|c| Some(*c)).collect();
            fine_edges = level.edges.clone();
            fine_nodes = level.nodes;
            let coarsest = level.nodes <= COARSEST_NODES;
            levels.push(level);
            if coarsest {
                break;
            }
        }
        (!levels.is_empty()).then_some(Self { levels })
    }

    /// Nodes on each coarse level.
    pub fn nodes(&self) -> Vec<usize> {
        self.levels.iter().map(|l| l.nodes).collect()
    }

    /// Whether the coarsest level is solved directly (it has at most `COARSEST_NODES` nodes; a
    /// hierarchy whose coarsening stalled above that, many small bodies or a mesh whose cells do
    /// not merge, sweeps its last level instead).
    pub fn solves_coarsest(&self) -> bool {
        self.levels
            .last()
            .is_some_and(|l| l.nodes <= COARSEST_NODES)
    }
}

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
pub struct Rows<T> {
    pub offsets: Vec<u32>,
    pub entries: Vec<T>,
}

impl<T: Copy> Rows<T> {
    pub fn build(rows: usize, items: impl Iterator<Item = (usize, T)> + Clone) -> Self {
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

    pub fn of(&self, r: usize) -> &[T] {
        &self.entries[self.offsets[r] as usize..self.offsets[r + 1] as usize]
    }
}

/// One coarse level's topology: built once per model.
#[derive(Debug, Clone)]
pub struct Level {
    pub nodes: usize,
    /// Each finer node's aggregate here (NONE for a pinned mass).
    pub parent: Vec<u32>,
    /// Each node's members on the finer level, in order.
    pub members: Rows<u32>,
    /// This level's edges (a < b).
    pub edges: Vec<[u32; 2]>,
    /// Each edge's finer edges; each node's finer edges to pinned masses.
    pub edge_sources: Rows<u32>,
    pub own_sources: Rows<u32>,
    /// Each node's edges and the node at their other end.
    pub incident: Rows<(u32, u32)>,
    /// Each node's body and lattice cell (its members' cells halved).
    pub cells: Vec<(u32, IVec3)>,
}

/// Each free mass's lattice cell on the finest level (None for a pinned one).
pub fn mass_cells(model: &Model) -> Vec<Option<(u32, IVec3)>> {
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
pub fn coarsen(fine: &[Option<(u32, IVec3)>], fine_edges: &[[u32; 2]]) -> Level {
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
