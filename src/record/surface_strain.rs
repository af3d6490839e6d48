//! The strain a surface's vertices show: each vertex's mass's most strained spring, or on a
//! reduced surface the most strained spring touching each vertex's block of masses.

use crate::model::{Model, SpringKindTag};

/// A spring end in no block.
pub(super) const NO_VERTEX: u32 = u32::MAX;

/// A reduced surface's vertices stand for blocks of masses: the structural springs that touch a
/// block, with the vertex of each end (`NO_VERTEX` where an end is in no block).
#[derive(Debug, Clone)]
pub(super) struct Blocks {
    /// Every k-th grid vertex along each axis.
    pub(super) stride: u32,
    pub(super) springs: Vec<[u32; 3]>,
}

/// What makes a reduced surface's vertex strains: its blocks' springs and how many vertices.
#[derive(Debug, Clone)]
pub(super) struct BlockStrain {
    pub(super) blocks: std::sync::Arc<Blocks>,
    pub(super) vertices: usize,
}

impl BlockStrain {
    pub(super) fn of(&self, strain: &[f32], out: &mut Vec<f32>) {
        block_strain(&self.blocks.springs, strain, self.vertices, out);
    }
}

/// The fewest springs [`block_strain`] gives a thread.
const BLOCK_CHUNK: usize = 1 << 16;

/// The signed strain of the most strained intact structural spring touching each vertex's block
/// (largest |strain|, the first in spring order on a tie; 0 where none), written into `out`.
/// Chunks of springs run in parallel and merge in order, so the result is that of one pass.
fn block_strain(springs: &[[u32; 3]], strain: &[f32], vertices: usize, out: &mut Vec<f32>) {
    use rayon::prelude::*;
    let stronger = |best: &mut f32, s: f32| {
        if s.abs() > best.abs() {
            *best = s;
        }
    };
    let pass = |chunk: &[[u32; 3]]| {
        let mut best = vec![0.0f32; vertices];
        for &[s, va, vb] in chunk {
            let e = strain[s as usize];
            if e.is_nan() {
                continue;
            }
            for v in [va, vb] {
                if v != NO_VERTEX {
                    stronger(&mut best[v as usize], e);
                }
            }
        }
        best
    };
    // One chunk per thread at most: each chunk fills a whole array of vertices.
    let chunk = BLOCK_CHUNK.max(springs.len().div_ceil(rayon::current_num_threads()));
    let merged = if springs.len() <= chunk {
        pass(springs)
    } else {
        springs
            .par_chunks(chunk)
            .map(pass)
            .reduce_with(|mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    stronger(x, y);
                }
                a
            })
            .unwrap_or_else(|| vec![0.0; vertices])
    };
    *out = merged;
}

/// The signed strain of the most strained intact structural spring at each mass of
/// `vertex_mass` (largest |strain|; every kind counts where the model has no structural spring;
/// 0 where none is intact), written into `out`.
pub fn vertex_strain(model: &Model, strain: &[f32], vertex_mass: &[u32], out: &mut Vec<f32>) {
    use rayon::prelude::*;
    let any_structural = model.spring_kind.contains(&SpringKindTag::Structural);
    out.clear();
    out.par_extend(vertex_mass.par_iter().map(|&m| {
        model
            .adjacency
            .of(m as usize)
            .iter()
            .filter(|nb| {
                !any_structural
                    || model.spring_kind[nb.spring as usize] == SpringKindTag::Structural
            })
            .map(|nb| strain[nb.spring as usize])
            .filter(|s| !s.is_nan())
            .fold(
                0.0f32,
                |best, s| if s.abs() > best.abs() { s } else { best },
            )
    }));
}
