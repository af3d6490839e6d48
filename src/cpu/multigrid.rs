//! An aggregation multigrid preconditioner for implicit Euler's conjugate gradients on large
//! systems (`physics::MULTIGRID_MIN_MASSES` masses and more).
//!
//! Block Jacobi leaves CG as slow as the system's condition number: a 256 × 256 cloth at one step
//! per frame (h²k/m ≈ 3 600) needs hundreds of iterations per solve and ran into the cap of 200
//! on most. A correction that spans the sheet has to travel there one spring per iteration.
//! Multigrid carries it on coarser copies of the system instead.
//!
//! - **Aggregates.** Level l + 1's nodes are blocks of two masses along each axis of level l's
//!   (2 × 2 on a sheet, 2 × 2 × 2 in a block): a grid body by its grid indices, a mesh body by
//!   cells of its rest positions twice its springs' mean rest length wide. Pinned masses belong to
//!   none (their Δv is zero). Coarsening stops at `COARSEST_NODES` nodes or when a level would not
//!   halve.
//! - **Coarse systems.** With P the piecewise-constant prolongation (a node's value copied to its
//!   members), the coarse system is Pᵀ A P. The system is a sum of each node's own block (mass,
//!   drag, contacts) and each spring's block S on its two ends (+S on the diagonal, −S off it),
//!   so Pᵀ A P is again such a sum: a coarse node's own block is the sum of its members' (and of
//!   the springs to pinned masses), a spring inside an aggregate vanishes, and the springs
//!   between two aggregates add into one coarse edge. No subtraction: the coarse blocks keep
//!   their precision however stiff the springs.
//! - **The cycle.** A V-cycle with one damped block-Jacobi sweep before and after the coarse
//!   correction (the same sweep: the cycle is a symmetric positive definite operator, as CG needs)
//!   and a dense Cholesky solve, in f64, on the coarsest level.
//!
//! Every sum runs in a fixed order, so the result does not depend on the thread count.

use glam::{DVec3, Mat3, Vec3};

use super::aggregates::Values;
use super::chunks::each_mass as each;
use super::multigrid_sweeps::{cholesky_in_place, residual, smooth, smooth_from_zero};
use crate::model::Model;
use crate::physics::hierarchy::{Hierarchy, Level};

/// The hierarchy, its numbers, and the coarsest level's factor.
#[derive(Debug, Clone)]
pub struct Multigrid {
    levels: Vec<Level>,
    values: Vec<Values>,
    /// The finest level's scratch (one vector per mass).
    fine_r: Vec<Vec3>,
    fine_ax: Vec<Vec3>,
    /// Lower-triangular Cholesky factor of the coarsest system, row-major, 3 unknowns a node,
    /// and whether it holds one (not when that level has more than `COARSEST_NODES` nodes or
    /// failed to factor: it then takes a Jacobi sweep); the solve's scratch.
    factor: Vec<f64>,
    factored: bool,
    coarse_y: Vec<f64>,
}

impl Multigrid {
    /// The hierarchy for `model`, or None when it would have no coarse level.
    pub fn new(model: &Model) -> Option<Self> {
        let levels = Hierarchy::new(model)?.levels;
        let values = levels
            .iter()
            .map(|l| Values {
                own: vec![Mat3::ZERO; l.nodes],
                edge: vec![Mat3::ZERO; l.edges.len()],
                diag_inv: vec![Mat3::IDENTITY; l.nodes],
                x: vec![Vec3::ZERO; l.nodes],
                b: vec![Vec3::ZERO; l.nodes],
                r: vec![Vec3::ZERO; l.nodes],
            })
            .collect();
        Some(Self {
            levels,
            values,
            fine_r: vec![Vec3::ZERO; model.mass_count()],
            fine_ax: vec![Vec3::ZERO; model.mass_count()],
            factor: Vec::new(),
            factored: false,
            coarse_y: Vec::new(),
        })
    }

    /// Nodes on each coarse level.
    #[cfg(test)]
    pub fn nodes(&self) -> Vec<usize> {
        self.levels.iter().map(|l| l.nodes).collect()
    }
}

impl Multigrid {
    /// The coarse levels' blocks at the current linearisation: `own(i)` is free mass i's own
    /// block (mass, drag, contacts), `spring(s)` spring s's block.
    pub fn linearise(
        &mut self,
        own: impl Fn(usize) -> Mat3 + Sync,
        spring: impl Fn(usize) -> Mat3 + Sync,
    ) {
        let Some((first, rest)) = self.values.split_first_mut() else {
            return;
        };
        self.levels[0].linearise(first, own, spring);
        let mut finer: &Values = first;
        for (level, v) in self.levels[1..].iter().zip(rest.iter_mut()) {
            level.linearise(v, |m| finer.own[m], |f| finer.edge[f]);
            finer = v;
        }
        self.factor_coarsest();
    }

    /// Factors the coarsest level's system into `factor`, in f64, in place (`factored` false if
    /// it is too large, or not positive definite in f64, which rounding alone could make it).
    fn factor_coarsest(&mut self) {
        self.factored = false;
        let (Some(level), Some(v)) = (self.levels.last(), self.values.last()) else {
            return;
        };
        // A hierarchy whose coarsening stalled above the coarsest size (many small bodies, a
        // mesh whose cells do not merge) sweeps its last level instead of factoring it.
        if level.nodes > crate::physics::hierarchy::COARSEST_NODES {
            return;
        }
        let n = 3 * level.nodes;
        let a = &mut self.factor;
        a.clear();
        a.resize(n * n, 0.0);
        let mut add = |r: usize, c: usize, m: Mat3, sign: f64| {
            let m = m.as_dmat3();
            for i in 0..3 {
                for j in 0..3 {
                    a[(3 * r + i) * n + 3 * c + j] += sign * m.col(j)[i];
                }
            }
        };
        for node in 0..level.nodes {
            add(node, node, v.own[node], 1.0);
        }
        for (e, &[p, q]) in level.edges.iter().enumerate() {
            let (p, q) = (p as usize, q as usize);
            add(p, p, v.edge[e], 1.0);
            add(q, q, v.edge[e], 1.0);
            add(p, q, v.edge[e], -1.0);
            add(q, p, v.edge[e], -1.0);
        }
        self.factored = cholesky_in_place(a, n);
    }

    /// x = A⁻¹ b on the coarsest level (a Jacobi sweep if it did not factor).
    fn solve_coarsest(&mut self) {
        let Some(v) = self.values.last_mut() else {
            return;
        };
        if !self.factored {
            smooth_from_zero(&v.diag_inv, &v.b, &mut v.x);
            return;
        }
        let (l, n) = (&self.factor, 3 * v.b.len());
        let y = &mut self.coarse_y;
        y.clear();
        y.extend(v.b.iter().flat_map(|b| b.as_dvec3().to_array()));
        for i in 0..n {
            let s = y[i] - (0..i).map(|k| l[i * n + k] * y[k]).sum::<f64>();
            y[i] = s / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s = y[i] - (i + 1..n).map(|k| l[k * n + i] * y[k]).sum::<f64>();
            y[i] = s / l[i * n + i];
        }
        for (node, x) in v.x.iter_mut().enumerate() {
            *x = DVec3::new(y[3 * node], y[3 * node + 1], y[3 * node + 2]).as_vec3();
        }
    }

    /// z = one cycle on r: the preconditioner CG applies. `block_inv` is each mass's inverted
    /// diagonal block, `apply(p, out)` the system's product.
    pub fn cycle(
        &mut self,
        block_inv: &[Mat3],
        apply: impl Fn(&[Vec3], &mut [Vec3]),
        r: &[Vec3],
        z: &mut [Vec3],
    ) {
        smooth_from_zero(block_inv, r, z);
        apply(z, &mut self.fine_ax);
        residual(r, &self.fine_ax, &mut self.fine_r);
        self.levels[0].restrict(&self.fine_r, &mut self.values[0].b);
        self.coarse_cycle(0);
        self.levels[0].prolong(&self.values[0].x, z);
        apply(z, &mut self.fine_ax);
        residual(r, &self.fine_ax, &mut self.fine_r);
        smooth(block_inv, &self.fine_r, z);
    }

    /// Coarse level k's x from its b: the coarsest solved directly, any other by a sweep, the
    /// next level's correction and a sweep (a V-cycle; a W-cycle, taking the correction twice,
    /// took a quarter fewer CG iterations on cloth-256 at 1/60 s in no less time on two cores).
    fn coarse_cycle(&mut self, k: usize) {
        if k + 1 == self.levels.len() {
            self.solve_coarsest();
            return;
        }
        {
            let v = &mut self.values[k];
            smooth_from_zero(&v.diag_inv, &v.b, &mut v.x);
        }
        self.hand_down(k);
        self.coarse_cycle(k + 1);
        let (here, below) = self.values.split_at_mut(k + 1);
        self.levels[k + 1].prolong(&below[0].x, &mut here[k].x);
        self.residual_at(k);
        let v = &mut self.values[k];
        smooth(&v.diag_inv, &v.r, &mut v.x);
    }

    /// Level k's r = b − A x.
    fn residual_at(&mut self, k: usize) {
        let Values {
            own, edge, x, b, r, ..
        } = &mut self.values[k];
        self.levels[k].apply((own, edge), x, r);
        each(r, |i, out| *out = b[i] - *out);
    }

    /// Level k's residual, restricted into level k + 1's b.
    fn hand_down(&mut self, k: usize) {
        self.residual_at(k);
        let (here, below) = self.values.split_at_mut(k + 1);
        self.levels[k + 1].restrict(&here[k].r, &mut below[0].b);
    }
}

#[cfg(test)]
mod tests {
    use super::super::forces::Gather;
    use super::super::implicit::{apply_system, block_of_mass, implicit_step, own_and_contacts};
    use super::super::implicit_work::{ImplicitWork, linearised_at};
    use super::super::system_blocks::invert_block;
    use super::*;
    use crate::integrator::Integrator;
    use crate::physics::Preconditioner;
    use crate::physics::hierarchy::NONE;

    /// A fixed pseudo-random vector per mass, in [−1, 1)³.
    fn noise(n: usize, seed: u32) -> Vec<Vec3> {
        let mut s = seed.wrapping_mul(2_654_435_761).wrapping_add(12_345);
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s as f32 / u32::MAX as f32) * 2.0 - 1.0
        };
        (0..n).map(|_| Vec3::new(next(), next(), next())).collect()
    }

    fn dot(a: &[Vec3], b: &[Vec3]) -> f64 {
        a.iter().zip(b).map(|(a, b)| f64::from(a.dot(*b))).sum()
    }

    /// cloth-64 (4 096 masses, two pinned) with its masses moved off the grid by up to a tenth
    /// of a spacing, so that springs are stretched, compressed and turned; the system
    /// linearised there at one step per frame, the hierarchy and the block inverses with it.
    fn linearised_cloth() -> (
        std::sync::Arc<Model>,
        super::super::implicit_work::Linearisation,
        Multigrid,
        Vec<Mat3>,
    ) {
        let crate::run::prepare::Planned { model, .. } =
            crate::run::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
        let h = 1.0 / 60.0;
        let spacing = model.springs[0].rest_m;
        let x: Vec<Vec3> = model
            .initial
            .x
            .iter()
            .zip(noise(model.mass_count(), 7))
            .map(|(x, d)| *x + 0.1 * spacing * d)
            .collect();
        let lin = linearised_at(&model, &x, h);
        let mut mg = Multigrid::new(&model).expect("a 64 × 64 sheet has coarse levels");
        mg.linearise(
            |i| own_and_contacts(&model, &lin, h, 0.0, i),
            |s| lin.springs[s].block(),
        );
        let block_inv = (0..model.mass_count())
            .map(|i| {
                if model.inv_mass[i] == 0.0 {
                    Mat3::IDENTITY
                } else {
                    invert_block(block_of_mass(&model, &lin, h, 0.0, i))
                }
            })
            .collect();
        (model, lin, mg, block_inv)
    }

    /// A 64 × 64 sheet coarsens 2 × 2 at a time down to the coarsest level's size.
    #[test]
    fn a_sheet_coarsens_by_blocks_of_two_by_two() {
        let (_, _, mg, _) = linearised_cloth();
        assert_eq!(mg.nodes(), vec![1024, 256, 64, 16]);
        // Every free mass has an aggregate; the two pinned corners have none.
        let parent = &mg.levels[0].parent;
        assert_eq!(parent.iter().filter(|&&p| p == NONE).count(), 2);
        assert!(
            mg.levels[0]
                .members
                .offsets
                .windows(2)
                .all(|w| w[1] - w[0] <= 4)
        );
    }

    /// Each coarse level's product is Pᵀ A P of the level above it: on the first, the masses'
    /// system applied to a coarse vector copied to its aggregates' members, summed back.
    #[test]
    fn the_coarse_system_is_the_galerkin_product() {
        let (model, lin, mg, _) = linearised_cloth();
        let h = 1.0 / 60.0;
        let level = &mg.levels[0];
        let v = &mg.values[0];
        let xc = noise(level.nodes, 3);
        let mut fine = vec![Vec3::ZERO; model.mass_count()];
        level.prolong(&xc, &mut fine);
        let mut a_fine = vec![Vec3::ZERO; model.mass_count()];
        apply_system(&model, &lin, h, &fine, &mut a_fine);
        let mut galerkin = vec![Vec3::ZERO; level.nodes];
        level.restrict(&a_fine, &mut galerkin);
        let mut direct = vec![Vec3::ZERO; level.nodes];
        level.apply((&v.own, &v.edge), &xc, &mut direct);
        let scale = galerkin.iter().map(|g| g.length()).fold(0.0f32, f32::max);
        let worst = galerkin
            .iter()
            .zip(&direct)
            .map(|(g, d)| (*g - *d).length())
            .fold(0.0f32, f32::max);
        assert!(worst <= 1e-4 * scale, "{worst} against {scale}");
    }

    /// CG needs its preconditioner symmetric positive definite: ⟨u, B v⟩ = ⟨B u, v⟩ to f32
    /// rounding, and ⟨u, B u⟩ > 0.
    #[test]
    fn a_cycle_is_symmetric_and_positive_definite() {
        let (model, lin, mut mg, block_inv) = linearised_cloth();
        let h = 1.0 / 60.0;
        let n = model.mass_count();
        let mut cycled = |r: &[Vec3]| {
            let mut z = vec![Vec3::ZERO; n];
            mg.cycle(
                &block_inv,
                |p, out| apply_system(&model, &lin, h, p, out),
                r,
                &mut z,
            );
            z
        };
        // The pinned masses' rows are not part of the system.
        let free = |mut v: Vec<Vec3>| {
            for (i, x) in v.iter_mut().enumerate() {
                if model.inv_mass[i] == 0.0 {
                    *x = Vec3::ZERO;
                }
            }
            v
        };
        let (u, w) = (free(noise(n, 11)), free(noise(n, 12)));
        let (bu, bw) = (cycled(&u), cycled(&w));
        let (ubw, buw) = (dot(&u, &bw), dot(&bu, &w));
        let size = dot(&u, &bu).abs().max(dot(&w, &bw).abs());
        assert!((ubw - buw).abs() <= 1e-4 * size, "{ubw} against {buw}");
        for seed in 20..24 {
            let u = free(noise(n, seed));
            assert!(dot(&u, &cycled(&u)) > 0.0);
        }
    }

    /// On cloth-64 at one step per frame, multigrid takes a fraction of block Jacobi's CG
    /// iterations, and the two end where the solver's tolerance allows: both solve the same
    /// equations to the same stopping rules. And a run gives the same bits on one thread as on
    /// the pool.
    #[test]
    fn multigrid_cuts_cg_iterations_and_keeps_the_answer() {
        let crate::run::prepare::Planned { model, .. } =
            crate::run::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
        let h = 1.0 / 60.0;
        let run = |p: Preconditioner| {
            let mut gather = Gather::new(&model);
            let mut work = ImplicitWork::new(&model, p);
            let mut state = model.initial.clone();
            let iterations: u32 = (0..30)
                .map(|_| {
                    implicit_step(
                        &model,
                        &mut gather,
                        &mut state,
                        &mut work,
                        Integrator::Implicit,
                        h,
                        &crate::backend::StopFlags::default(),
                    )
                    .iterations
                })
                .sum();
            (iterations, state)
        };
        let (jacobi, js) = run(Preconditioner::BlockJacobi);
        let (multigrid, ms) = run(Preconditioner::Multigrid);
        assert!(
            3 * multigrid <= jacobi,
            "{multigrid} against {jacobi} iterations"
        );
        let apart =
            js.x.iter()
                .zip(&ms.x)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max);
        // Half a second of a 1 m cloth falling from two corners, each step's equations held to
        // 3% of its momentum change.
        eprintln!(
            "cloth-64, 30 steps at 1/60 s: CG iterations {jacobi} (block Jacobi), {multigrid} (multigrid); ends {apart:.2e} m apart"
        );
        assert!(apart < 2e-2, "{apart} m apart");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a one-thread pool")
            .install(|| run(Preconditioner::Multigrid));
        assert_eq!(one.0, multigrid);
        assert!(one.1.x == ms.x && one.1.v == ms.v);
    }
}
