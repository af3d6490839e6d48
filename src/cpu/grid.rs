//! The uniform hash grid that mass–mass contact searches: cells `2 · radius` wide, so that a
//! touching pair lies in the same or neighbouring cells; integer cell coordinates hashed into a
//! power-of-two table; the masses counting-sorted by bucket. Mirrors `shaders/grid.wgsl`: the
//! same cell, hash and table, so both backends visit the same candidates in the same order.

use glam::{DVec3, IVec3, Vec3};

use crate::physics::{inv_cell_per_m, table_size};

/// The cell holding `p`. Same operations as `grid_cell` in `shaders/common.wgsl` (multiply by the
/// inverse cell size, floor, convert with saturation), so both backends bin a mass alike.
#[inline(always)]
pub fn grid_cell(p: Vec3, inv_cell_per_m: f32) -> IVec3 {
    (p * inv_cell_per_m).floor().as_ivec3()
}

/// The bucket of cell `c`: large odd multipliers mix the coordinates (Teschner et al. 2003).
#[inline(always)]
pub fn grid_hash(c: IVec3, mask: u32) -> u32 {
    ((c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791))
        & mask
}

/// The masses binned by bucket: bucket `b` holds `sorted[cell_start[b]..cell_start[b + 1]]`, in
/// increasing mass index.
#[derive(Debug, Clone)]
pub struct MassGrid {
    inv_cell_per_m: f32,
    mask: u32,
    pub cell_start: Vec<u32>,
    pub sorted: Vec<u32>,
    /// Cell and bucket of each mass, from the last build.
    cell: Vec<IVec3>,
    mass_cell: Vec<u32>,
    /// Next free slot of each bucket while scattering.
    fill: Vec<u32>,
}

impl MassGrid {
    /// Cells `2 · radius_m` wide: a touching pair lies in the same or neighbouring cells.
    pub fn new(mass_count: usize, radius_m: f32) -> Self {
        Self::with_inv_cell(mass_count, inv_cell_per_m(radius_m))
    }

    /// Cells `1 / inv_cell_per_m` wide.
    pub fn with_inv_cell(mass_count: usize, inv_cell_per_m: f32) -> Self {
        let table = table_size(mass_count) as usize;
        Self {
            inv_cell_per_m,
            mask: table as u32 - 1,
            cell_start: vec![0; table + 1],
            sorted: vec![0; mass_count],
            cell: vec![IVec3::ZERO; mass_count],
            mass_cell: vec![0; mass_count],
            fill: vec![0; table],
        }
    }

    pub fn inv_cell_per_m(&self) -> f32 {
        self.inv_cell_per_m
    }

    pub fn table_size(&self) -> u32 {
        self.mask + 1
    }

    /// Bin the masses at positions `x`.
    pub fn build(&mut self, x: &[Vec3]) {
        let inv = self.inv_cell_per_m;
        self.build_from(x.len(), |i| grid_cell(x[i], inv));
    }

    /// Bin f64 positions (the accuracy benchmark's reference), cells computed in f64.
    pub fn build_f64(&mut self, x: &[DVec3]) {
        let inv = f64::from(self.inv_cell_per_m);
        self.build_from(x.len(), |i| (x[i] * inv).floor().as_ivec3());
    }

    /// Counting sort by bucket: `grid_count`, then the exclusive prefix sum over the table (the
    /// GPU's `grid_scan_*` passes), then `grid_scatter`. Scattering in mass order leaves each
    /// bucket sorted, the order the GPU's `grid_sort_cells` restores after its atomic scatter.
    fn build_from(&mut self, n: usize, cell: impl Fn(usize) -> IVec3) {
        for (i, c) in self.cell[..n].iter_mut().enumerate() {
            *c = cell(i);
        }
        self.grid_count(n);
        let mut sum = 0u32;
        for (start, count) in self.cell_start.iter_mut().zip(self.fill.iter_mut()) {
            *start = sum;
            sum += *count;
            // From here on `fill` is each bucket's next free slot.
            *count = *start;
        }
        self.cell_start[self.mask as usize + 1] = sum;
        self.grid_scatter(n);
    }

    /// Each mass's bucket (its cell is in `cell`), and the masses in each bucket (into `fill`).
    pub fn grid_count(&mut self, n: usize) {
        self.fill.fill(0);
        for i in 0..n {
            let b = grid_hash(self.cell[i], self.mask);
            self.mass_cell[i] = b;
            self.fill[b as usize] += 1;
        }
    }

    /// Each mass into the next free slot of its bucket, in mass order.
    pub fn grid_scatter(&mut self, n: usize) {
        for i in 0..n {
            let slot = &mut self.fill[self.mass_cell[i] as usize];
            self.sorted[*slot as usize] = i as u32;
            *slot += 1;
        }
    }

    /// The masses in bucket `b`, in increasing index.
    #[inline(always)]
    pub fn bucket(&self, b: u32) -> &[u32] {
        &self.sorted[self.cell_start[b as usize] as usize..self.cell_start[b as usize + 1] as usize]
    }

    /// Every mass in the 27 cells around (and including) cell `c`, each once, in the order both
    /// backends gather: cell by cell (z outermost, then y, then x, each from −1 to +1), by mass
    /// index within a cell. A bucket holds every cell that hashes to it, so only the masses of
    /// the cell being searched are taken from it: a bucket that two of the 27 cells share yields
    /// each of its masses once, under its own cell, and masses of far cells are never visited.
    #[inline(always)]
    pub fn for_each_candidate(&self, c: IVec3, mut visit: impl FnMut(usize)) {
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let n = IVec3::new(
                        c.x.wrapping_add(dx),
                        c.y.wrapping_add(dy),
                        c.z.wrapping_add(dz),
                    );
                    for &j in self.bucket(grid_hash(n, self.mask)) {
                        if self.cell[j as usize] == n {
                            visit(j as usize);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::SCAN_BLOCK;

    /// A small deterministic generator (no new dependency for a test).
    fn cloud(n: usize, seed: u64, extent_m: f32) -> Vec<Vec3> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((s >> 40) as f32) / ((1u64 << 24) as f32)
        };
        (0..n)
            .map(|_| Vec3::new(next(), next(), next()) * extent_m - Vec3::splat(0.5 * extent_m))
            .collect()
    }

    #[test]
    fn every_mass_is_binned_once_and_buckets_are_sorted() {
        let x = cloud(3000, 7, 1.0);
        let mut g = MassGrid::new(x.len(), 0.02);
        g.build(&x);
        let mut seen = g.sorted.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..x.len() as u32).collect::<Vec<_>>());
        for b in 0..g.table_size() {
            let bucket = g.bucket(b);
            assert!(
                bucket.windows(2).all(|w| w[0] < w[1]),
                "bucket {b} unsorted"
            );
            for &i in bucket {
                assert_eq!(
                    grid_hash(grid_cell(x[i as usize], g.inv_cell_per_m), g.mask),
                    b
                );
            }
        }
    }

    /// The hash grid's candidates, filtered by distance, are exactly the brute-force pairs within
    /// 2r: on a random cloud dense enough that many pairs touch and many buckets are shared by
    /// several cells (table of 1024 buckets for 500 masses spread over ~15³ cells).
    #[test]
    fn grid_pairs_equal_brute_force_pairs() {
        for (seed, radius) in [(1u64, 0.02f32), (2, 0.05), (3, 0.011)] {
            let x = cloud(500, seed, 0.6);
            let mut g = MassGrid::new(x.len(), radius);
            g.build(&x);
            let d2 = (2.0 * radius) * (2.0 * radius);
            let mut brute = Vec::new();
            for i in 0..x.len() {
                for j in i + 1..x.len() {
                    if x[i].distance_squared(x[j]) < d2 {
                        brute.push((i, j));
                    }
                }
            }
            // Masses whose 27 cells hash to fewer than 27 buckets: the case where a bucket
            // must not yield its masses twice.
            let shared = x
                .iter()
                .filter(|&&p| {
                    let c = grid_cell(p, g.inv_cell_per_m);
                    let mut buckets: Vec<u32> = (0..27)
                        .map(|o| {
                            let d = IVec3::new(o % 3 - 1, (o / 3) % 3 - 1, o / 9 - 1);
                            grid_hash(c + d, g.mask)
                        })
                        .collect();
                    buckets.sort_unstable();
                    buckets.dedup();
                    buckets.len() < 27
                })
                .count();
            assert!(
                shared > 10,
                "radius {radius}: only {shared} masses see a shared bucket"
            );
            let mut grid = Vec::new();
            for (i, &xi) in x.iter().enumerate() {
                let mut count = std::collections::HashMap::new();
                g.for_each_candidate(grid_cell(xi, g.inv_cell_per_m), |j| {
                    *count.entry(j).or_insert(0) += 1;
                    if j > i && xi.distance_squared(x[j]) < d2 {
                        grid.push((i, j));
                    }
                });
                assert!(
                    count.values().all(|&c| c == 1),
                    "a candidate of mass {i} was visited twice"
                );
            }
            grid.sort_unstable();
            assert!(
                brute.len() > 20,
                "radius {radius}: only {} pairs",
                brute.len()
            );
            assert_eq!(grid, brute, "seed {seed}, radius {radius}");
        }
    }

    #[test]
    fn the_table_is_a_power_of_two_of_whole_scan_blocks() {
        for n in [0usize, 1, 100, 128, 129, 5000, 1 << 20] {
            let t = table_size(n);
            assert!(t.is_power_of_two() && t.is_multiple_of(SCAN_BLOCK) && t as usize >= 2 * n);
        }
    }
}
