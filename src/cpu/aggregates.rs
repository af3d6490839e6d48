//! Each coarse level's numbers for the CPU's multigrid cycle (`multigrid.rs`) at the current
//! linearisation, and the level's products over them; the levels themselves are
//! `crate::physics::hierarchy`'s, shared with the GPU.

use glam::{Mat3, Vec3};

use super::chunks::each_mass as each;
use super::system_blocks::invert_block;
use crate::physics::hierarchy::{Level, NONE};

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
