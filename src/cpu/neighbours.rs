//! Mass–mass contact's neighbour lists (Verlet lists with a skin): each mass's list holds the
//! masses it may touch that lay within `2 r + skin` of it when the lists were built
//! (`physics::neighbour_reach_m`), in increasing mass index. The lists are rebuilt, through the
//! hash grid ([`MassGrid`], cells one reach wide), only once some mass has moved past
//! `physics::neighbour_moved_limit_m` since the last build; until then every pair that can touch
//! is still in them, so a force evaluation walks a short list instead of 27 grid cells.
//!
//! The order is the one both backends sum a mass's pairs in (`shaders/collide_masses.wgsl`
//! merges its grid buckets into it): the touching pairs by increasing index. It depends on no
//! grid, skin or build time, so when the lists are rebuilt never changes a result.

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use super::grid::{MassGrid, grid_cell};
use crate::model::{MassContact, Model};
use crate::physics::{neighbour_moved_limit_m, neighbour_reach_m};

/// Whether masses `i` and `j` may touch at all: the scene's rule on bodies, and not both pinned
/// (two pinned masses exert nothing on each other).
#[inline(always)]
pub(super) fn may_touch(model: &Model, c: &MassContact, i: usize, j: usize) -> bool {
    j != i
        && (c.within_bodies || model.mass_body[i] != model.mass_body[j])
        && model.inv_mass[i] + model.inv_mass[j] != 0.0
}

#[derive(Debug, Clone)]
pub struct Neighbours {
    grid: MassGrid,
    reach_sq: f32,
    moved_sq: f32,
    /// Positions at the last build; empty before the first.
    x_ref: Vec<Vec3>,
    /// Mass `i`'s list is `list[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    list: Vec<u32>,
    builds: u64,
}

impl Neighbours {
    pub fn new(mass_count: usize, c: &MassContact) -> Self {
        let reach = neighbour_reach_m(c.radius_m);
        let moved = neighbour_moved_limit_m(c.radius_m);
        Self {
            grid: MassGrid::with_inv_cell(mass_count, 1.0 / reach),
            reach_sq: reach * reach,
            moved_sq: moved * moved,
            x_ref: Vec::new(),
            offsets: vec![0; mass_count + 1],
            list: Vec::new(),
            builds: 0,
        }
    }

    /// Lists built at `x`, for a one-off use (a snapshot's energy).
    pub fn built_at(model: &Model, c: &MassContact, x: &[Vec3]) -> Self {
        let mut n = Self::new(x.len(), c);
        n.neighbour_lists(model, c, x);
        n
    }

    /// Make the lists hold every pair that can touch at positions `x`: rebuilt there when some
    /// mass has moved past the limit since the last build (or there was none). Returns whether
    /// it rebuilt.
    pub fn update(&mut self, model: &Model, c: &MassContact, x: &[Vec3]) -> bool {
        if !self.neighbours_check(x) {
            return false;
        }
        self.neighbour_lists(model, c, x);
        true
    }

    /// How many times the lists have been built.
    pub fn builds(&self) -> u64 {
        self.builds
    }

    /// Mass `i`'s list, in increasing index.
    #[inline(always)]
    pub fn of(&self, i: usize) -> &[u32] {
        &self.list[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Whether some mass of `x` has moved past the limit since the last build (or is not
    /// finite): the lists are stale.
    pub(crate) fn neighbours_check(&self, x: &[Vec3]) -> bool {
        if self.x_ref.len() != x.len() {
            return true;
        }
        let moved = |(a, b): (&[Vec3], &[Vec3])| {
            a.iter().zip(b).any(|(p, q)| {
                // Not within the limit, rather than past it: a NaN position makes the
                // lists stale too.
                let within = p.distance_squared(*q) <= self.moved_sq;
                !within
            })
        };
        if x.len() >= PARALLEL_MIN_MASSES {
            x.par_chunks(CHUNK)
                .zip(self.x_ref.par_chunks(CHUNK))
                .any(moved)
        } else {
            moved((x, &self.x_ref))
        }
    }

    /// Build the lists at `x`: the grid, then each mass's candidates within the reach.
    pub(crate) fn neighbour_lists(&mut self, model: &Model, c: &MassContact, x: &[Vec3]) {
        self.grid.build(x);
        self.x_ref.clear();
        self.x_ref.extend_from_slice(x);
        let (grid, reach_sq) = (&self.grid, self.reach_sq);
        // Each chunk's lists, concatenated in chunk order: the same lists whatever the threads.
        let chunk_lists = |ci: usize| -> (Vec<u32>, Vec<u32>) {
            let (mut lens, mut list) = (Vec::new(), Vec::new());
            let end = ((ci + 1) * CHUNK).min(x.len());
            for i in ci * CHUNK..end {
                let start = list.len();
                grid.for_each_candidate(grid_cell(x[i], grid.inv_cell_per_m()), |j| {
                    if may_touch(model, c, i, j) && x[i].distance_squared(x[j]) < reach_sq {
                        list.push(j as u32);
                    }
                });
                list[start..].sort_unstable();
                lens.push((list.len() - start) as u32);
            }
            (lens, list)
        };
        let chunks = x.len().div_ceil(CHUNK);
        let parts: Vec<(Vec<u32>, Vec<u32>)> = if x.len() >= PARALLEL_MIN_MASSES {
            (0..chunks).into_par_iter().map(chunk_lists).collect()
        } else {
            (0..chunks).map(chunk_lists).collect()
        };
        self.list.clear();
        let mut i = 0;
        for (lens, list) in parts {
            for len in lens {
                self.offsets[i + 1] = self.offsets[i] + len;
                i += 1;
            }
            self.list.extend_from_slice(&list);
        }
        self.builds += 1;
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::model::{ContactModel, Effects, ModelBuilder, damping_ratio_for_restitution};

    fn cloud_model(n: usize, seed: u32, extent_m: f32, c: MassContact) -> Model {
        let mut mb = ModelBuilder::new();
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (s >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        for _ in 0..n {
            let p = Vec3::new(next(), next(), next()) * extent_m;
            mb.mass(p, Vec3::ZERO, 0.01, false);
        }
        mb.effects(Effects {
            self_collision: Some(c),
            ..Effects::default()
        });
        mb.build()
    }

    /// Mass contact of `radius_m` with a firm spring, some friction and a bounce.
    pub(in crate::cpu) fn contact(radius_m: f32) -> MassContact {
        MassContact {
            radius_m,
            contact: ContactModel {
                stiffness_n_per_m: 500.0,
                friction: 0.3,
                damping_ratio: damping_ratio_for_restitution(0.3),
            },
            within_bodies: true,
        }
    }

    /// The pairs within `d` at `x`, by brute force, each mass's in increasing index.
    fn brute(model: &Model, c: &MassContact, x: &[Vec3], d: f32) -> Vec<Vec<u32>> {
        (0..x.len())
            .map(|i| {
                (0..x.len())
                    .filter(|&j| may_touch(model, c, i, j) && x[i].distance(x[j]) < d)
                    .map(|j| j as u32)
                    .collect()
            })
            .collect()
    }

    /// Built at x, the lists are exactly the brute-force pairs within the reach. Every mass is
    /// then moved by up to the limit, in random directions: the lists are not rebuilt, and every
    /// pair now touching (within 2r) is still in them.
    #[test]
    fn lists_hold_every_touching_pair_until_a_mass_moves_past_the_limit() {
        let c = contact(0.03);
        let model = cloud_model(800, 9, 0.8, c);
        let x0 = model.initial.x.clone();
        let mut nb = Neighbours::new(x0.len(), &c);
        assert!(nb.update(&model, &c, &x0));
        let reach = neighbour_reach_m(c.radius_m);
        let want = brute(&model, &c, &x0, reach);
        for (i, w) in want.iter().enumerate() {
            assert_eq!(nb.of(i), w.as_slice(), "mass {i}");
        }
        assert!(want.iter().map(Vec::len).sum::<usize>() > 400);

        let limit = neighbour_moved_limit_m(c.radius_m);
        let mut s = 77u32;
        let mut next = || {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (s >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let x1: Vec<Vec3> = x0
            .iter()
            .map(|&p| {
                let dir = Vec3::new(next(), next(), next()).normalize_or_zero();
                p + dir * (limit * 0.999)
            })
            .collect();
        assert!(!nb.update(&model, &c, &x1), "rebuilt within the limit");
        let touching = brute(&model, &c, &x1, 2.0 * c.radius_m);
        let mut pairs = 0;
        for (i, t) in touching.iter().enumerate() {
            for j in t {
                assert!(nb.of(i).contains(j), "pair ({i}, {j}) missing");
                pairs += 1;
            }
        }
        assert!(pairs > 100, "only {pairs} touching pairs");

        // One mass past the limit makes them stale.
        let mut x2 = x1.clone();
        x2[5] = x0[5] + Vec3::X * (limit * 1.01);
        assert!(nb.update(&model, &c, &x2));
        assert_eq!(nb.builds(), 2);
    }

    /// Pinned pairs and, without `within_bodies`, pairs of one body are never listed.
    #[test]
    fn lists_skip_pairs_that_cannot_touch() {
        let mut mb = ModelBuilder::new();
        mb.mass(Vec3::ZERO, Vec3::ZERO, 1.0, true);
        mb.mass(Vec3::X * 0.01, Vec3::ZERO, 1.0, true);
        mb.mass(Vec3::Y * 0.01, Vec3::ZERO, 1.0, false);
        let c = contact(0.02);
        mb.effects(Effects {
            self_collision: Some(c),
            ..Effects::default()
        });
        let model = mb.build();
        let nb = Neighbours::built_at(&model, &c, &model.initial.x);
        assert_eq!(nb.of(0), &[2]);
        assert_eq!(nb.of(1), &[2]);
        assert_eq!(nb.of(2), &[0, 1]);
        let apart = MassContact {
            within_bodies: false,
            ..c
        };
        let nb = Neighbours::built_at(&model, &apart, &model.initial.x);
        assert!((0..3).all(|i| nb.of(i).is_empty()));
    }
}
