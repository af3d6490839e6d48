//! The hierarchy, its coarse systems, its cycle, and what it does to implicit Euler's solves.

use super::super::forces::Gather;
use super::super::implicit::{
    ImplicitWork, apply_system, block_of_mass, implicit_step, linearised_at, own_and_contacts,
};
use super::hierarchy::NONE;
use super::*;
use crate::cpu::system_blocks::invert_block;
use crate::physics::Preconditioner;

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
    super::super::implicit::Linearisation,
    Multigrid,
    Vec<Mat3>,
) {
    let crate::prepare::Planned { model, .. } =
        crate::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
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
    assert_eq!(mg.nodes(), vec![1024, 256, 64]);
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
    let crate::prepare::Planned { model, .. } =
        crate::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
    let h = 1.0 / 60.0;
    let run = |p: Preconditioner| {
        let mut gather = Gather::new(&model);
        let mut work = ImplicitWork::new(&model, p);
        let mut state = model.initial.clone();
        let iterations: u32 = (0..30)
            .map(|_| implicit_step(&model, &mut gather, &mut state, &mut work, h).iterations)
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
