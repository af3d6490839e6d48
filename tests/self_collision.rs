//! Mass–mass contact (`[effects.self_collision]`): a head-on pair bounces with the stated
//! restitution and conserves momentum and energy, bodies that may not touch pass through each
//! other, a folding cloth never lets two of its masses meet, and the GPU's hash grid and contact
//! match the CPU's. GPU tests skip without an adapter unless HOOKE_REQUIRE_ADAPTER=1.

use crate::common;

use std::sync::Arc;

use crate::common::parity::{cpu_and_gpu, run_pair};
use crate::common::{gpu_available, ok, scene_model};

use glam::Vec3;
use hooke::backend::Backend;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step};
use hooke::model::{
    BodyShape, ContactModel, Effects, MassContact, Model, ModelBuilder,
    damping_ratio_for_restitution,
};
use hooke::state::State;

const RADIUS_M: f32 = 0.02;
const STIFFNESS_N_PER_M: f32 = 500.0;
const MASS_KG: f32 = 0.01;

/// Two free masses on the x axis, 10 cm apart, approaching each other at `speed` each; no
/// springs, no gravity. `one_body`: both in the same body (else one body each).
fn head_on(restitution: f32, within_bodies: bool, one_body: bool, speed: f32) -> Arc<Model> {
    let mut mb = ModelBuilder::new();
    mb.mass(
        Vec3::new(-0.05, 0.3, 0.0),
        Vec3::new(speed, 0.0, 0.0),
        MASS_KG,
        false,
    );
    if !one_body {
        mb.end_body("left", BodyShape::Grid(vec![1]));
    }
    mb.mass(
        Vec3::new(0.05, 0.3, 0.0),
        Vec3::new(-speed, 0.0, 0.0),
        MASS_KG,
        false,
    );
    mb.end_body("right", BodyShape::Grid(vec![if one_body { 2 } else { 1 }]));
    mb.effects(Effects {
        self_collision: Some(MassContact {
            radius_m: RADIUS_M,
            contact: ContactModel {
                stiffness_n_per_m: STIFFNESS_N_PER_M,
                friction: 0.0,
                damping_ratio: damping_ratio_for_restitution(restitution),
            },
            within_bodies,
        }),
        ..Effects::default()
    });
    Arc::new(mb.build())
}

struct Track {
    min_distance_m: f32,
    end: State,
    /// Largest |energy balance − initial| over the run, and the contact energy stored midway
    /// through the impact (the largest seen).
    worst_balance_j: f64,
    peak_contact_j: f64,
}

fn track(model: &Arc<Model>, integrator: Integrator, dt: f64, steps: u32) -> Track {
    let mut be = CpuBackend::new(model.clone(), Step::new(integrator, dt));
    let e0 = ok(be.snapshot(0, Default::default())).energies.balance_j();
    let mut t = Track {
        min_distance_m: f32::INFINITY,
        end: model.initial.clone(),
        worst_balance_j: 0.0,
        peak_contact_j: 0.0,
    };
    for _ in 0..steps {
        ok(be.advance(1));
        let s = ok(be.snapshot(0, Default::default()));
        t.min_distance_m = t
            .min_distance_m
            .min(s.positions[0].distance(s.positions[1]));
        t.worst_balance_j = t.worst_balance_j.max((s.energies.balance_j() - e0).abs());
        t.peak_contact_j = t.peak_contact_j.max(s.energies.contact_j);
    }
    t.end = ok(be.state());
    t
}

/// A head-on impact at 2 m/s closing speed: the pair bounces apart with the stated coefficient
/// of restitution, momentum is conserved, the closest approach is within the undamped spring's
/// bound, and the energy balance (kinetic + pair potential + dissipated) holds through the
/// impact, with the pair potential carrying a real share of it midway.
#[test]
fn a_head_on_pair_bounces_with_its_restitution_and_conserves_momentum() {
    let speed = 1.0f32;
    let closing = 2.0 * speed;
    // The contact lasts about π sqrt(μ/k) = 10 ms; 1e-5 s steps resolve it finely.
    // (Below e = 0.2 the damper, on from before the touch, leaves less than a third of the
    // undamped compression: a fifth at e = 0.1, laws::contact_law.)
    for (e, integrator) in [
        (0.2f32, Integrator::SemiImplicit),
        (0.5, Integrator::Verlet),
        (0.9, Integrator::Rk4),
    ] {
        let model = head_on(e, true, false, speed);
        let t = track(&model, integrator, 1e-5, 6000);
        let (v0, v1) = (t.end.v[0], t.end.v[1]);
        let momentum = MASS_KG * (v0 + v1);
        assert!(
            momentum.length() < 1e-7,
            "{integrator} e={e}: momentum {momentum} after the impact (was 0)"
        );
        let separating = v1.x - v0.x;
        let measured = separating / closing;
        assert!(
            (measured - e).abs() <= 0.01,
            "{integrator}: restitution {measured:.4}, stated {e}"
        );
        // Undamped, the pair would sink closing · sqrt(μ / k) into each other; damping only
        // lessens that.
        let mu = 0.5 * MASS_KG;
        let deepest = closing * (mu / STIFFNESS_N_PER_M).sqrt();
        let bound = 2.0 * RADIUS_M - deepest;
        assert!(
            t.min_distance_m >= bound - 1e-5,
            "{integrator} e={e}: came to {} m, bound {bound} m",
            t.min_distance_m
        );
        assert!(
            t.min_distance_m < 2.0 * RADIUS_M - 0.3 * deepest,
            "{integrator} e={e}: closest approach {} m: the contact is stiffer than stated",
            t.min_distance_m
        );
        let kinetic0 = f64::from(MASS_KG * speed * speed);
        assert!(
            t.peak_contact_j > 0.05 * kinetic0,
            "{integrator} e={e}: the pair potential never held energy ({} J)",
            t.peak_contact_j
        );
        // First order: an error of order ω·dt (0.3% here) of the energy in play; second and
        // fourth order: far less. Either is well below the energy the pair potential holds and
        // the impact dissipates, so a missing term would show.
        let tolerance = if integrator == Integrator::SemiImplicit {
            1e-2
        } else {
            1e-4
        };
        assert!(
            t.worst_balance_j < tolerance * kinetic0
                && tolerance * kinetic0 < 0.5 * t.peak_contact_j,
            "{integrator} e={e}: energy balance off by {} J (kinetic energy {kinetic0} J)",
            t.worst_balance_j
        );
        println!(
            "{integrator} e={e}: restitution {measured:.4}, closest {:.5} m (bound {bound:.5}), balance error {:.2e} J",
            t.min_distance_m, t.worst_balance_j
        );
    }
}

/// With `within_bodies = false`, two masses of one body pass through each other untouched;
/// the same two masses as two bodies bounce.
#[test]
fn masses_of_one_body_pass_through_each_other_when_only_bodies_collide() {
    let through = track(
        &head_on(0.5, false, true, 1.0),
        Integrator::SemiImplicit,
        1e-5,
        6000,
    );
    assert!(
        through.min_distance_m < 1e-3,
        "they should have met, closest {}",
        through.min_distance_m
    );
    assert_eq!(
        through.end.v[0],
        Vec3::new(1.0, 0.0, 0.0),
        "mass 0 was pushed"
    );
    assert_eq!(
        through.end.v[1],
        Vec3::new(-1.0, 0.0, 0.0),
        "mass 1 was pushed"
    );
    let bounced = track(
        &head_on(0.5, false, false, 1.0),
        Integrator::SemiImplicit,
        1e-5,
        6000,
    );
    assert!(
        bounced.end.v[0].x < 0.0 && bounced.end.v[1].x > 0.0,
        "two bodies should bounce apart: {:?}",
        bounced.end.v
    );
}

/// Smallest distance between any two masses (brute force).
fn min_distance(x: &[Vec3]) -> (f32, usize, usize) {
    let mut best = (f32::INFINITY, 0, 0);
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let d = x[i].distance_squared(x[j]);
            if d < best.0 {
                best = (d, i, j);
            }
        }
    }
    (best.0.sqrt(), best.1, best.2)
}

/// cloth-fold for its first 1.5 s (landing, folding and crumpling onto itself): no two masses
/// of the cloth ever come closer than half the contact radius, and the cloth does fold onto
/// itself (many pairs that are far apart in the grid end up touching).
#[test]
fn the_folding_cloth_never_lets_two_masses_meet() {
    let (model, dt) = scene_model("cloth-fold");
    let radius = model.effects.self_collision.map_or(0.0, |c| c.radius_m);
    assert!(radius > 0.0, "cloth-fold has no self_collision");
    let mut be = CpuBackend::new(model.clone(), Step::new(Integrator::SemiImplicit, dt));
    let substeps = (1.0 / (60.0 * dt)).round() as u32;
    let mut closest = (f32::INFINITY, 0, 0, 0);
    for frame in 1..=90 {
        ok(be.advance(substeps));
        let s = ok(be.snapshot(frame, Default::default()));
        let (d, i, j) = min_distance(&s.positions);
        if d < closest.0 {
            closest = (d, i, j, frame);
        }
    }
    let end = ok(be.state());
    // Masses more than 3 grid steps apart in the sheet that now touch: the sheet lies on itself.
    let n = 32;
    let far_touching = (0..end.x.len())
        .flat_map(|i| (i + 1..end.x.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| {
            let (gi, gj) = ((i % n, i / n), (j % n, j / n));
            gi.0.abs_diff(gj.0).max(gi.1.abs_diff(gj.1)) > 3
                && end.x[i].distance(end.x[j]) < 2.5 * radius
        })
        .count();
    println!(
        "cloth-fold: closest approach {:.4} m ({:.2} radius) between masses {} and {} at frame {}; {far_touching} far-apart pairs touching at 1.5 s",
        closest.0,
        closest.0 / radius,
        closest.1,
        closest.2,
        closest.3
    );
    assert!(
        far_touching > 50,
        "the cloth did not fold onto itself ({far_touching} far-apart pairs touching)"
    );
    assert!(
        closest.0 >= 0.5 * radius,
        "masses {} and {} came {} m apart at frame {} (radius {radius} m)",
        closest.1,
        closest.2,
        closest.0,
        closest.3
    );
}

// ---- The GPU against the CPU. ----

/// Both backends over `frames` frames of `substeps` steps, compared at every frame: the largest
/// position difference, and each backend's last snapshot.
fn run_both(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    frames: u32,
    substeps: u32,
) -> (f64, hooke::state::Snapshot, hooke::state::Snapshot) {
    let (mut cpu, mut gpu) = cpu_and_gpu(model, Step::new(integrator, dt));
    run_pair((&mut cpu, &mut gpu), (frames, substeps), &mut |_, _| {})
}

/// How far the CPU parts from itself when its start moves by one f32 step
/// (`common::parity::nudged`, `NUDGED_STARTS` of them): the largest position difference over
/// the frames, and of the contact, kinetic and dissipated energies at the end.
fn nudged_spread(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    frames: u32,
    substeps: u32,
) -> (f64, [f64; 3]) {
    (1..=NUDGED_STARTS).fold((0.0, [0.0; 3]), |(worst, energies), seed| {
        let step = Step::new(integrator, dt);
        let (x, c, n) = run_pair(
            (
                &mut CpuBackend::new(model.clone(), step),
                &mut CpuBackend::new(common::parity::nudged(model, seed), step),
            ),
            (frames, substeps),
            &mut |_, _| {},
        );
        let apart = aggregates(&c).into_iter().zip(aggregates(&n));
        let mut energies = energies;
        for (e, (a, b)) in energies.iter_mut().zip(apart) {
            *e = f64::max(*e, (a - b).abs());
        }
        (f64::max(worst, x), energies)
    })
}

/// The contact, kinetic and dissipated energies of a snapshot.
fn aggregates(s: &hooke::state::Snapshot) -> [f64; 3] {
    let e = s.energies;
    [e.contact_j, e.kinetic_j, e.ledger.dissipated_j()]
}

/// Starts moved by one f32 step that `gpu_matches_cpu_with_mass_contact` also runs the CPU from.
const NUDGED_STARTS: u64 = 2;

/// Stated tolerance, as the other parity tests: lavapipe evaluates the same f32 operations in
/// the same order as the CPU (bit-identical in practice); a GPU that fuses multiply-adds differs
/// by rounding, which contact amplifies, so 1e-4 m over these frames.
const PARITY_X_M: f64 = 1e-4;

/// pile (cubes landing on each other from 0.15 s) and cloth-fold (the sheet landing and folding
/// from 0.4 s), with the integrators whose force evaluations read different states (x, v; the
/// RK4 stages' xt, vt; Verlet's x, vt): positions agree at every frame, and so do the contact
/// energy (the pair potential) and the dissipated energy. Where the GPU rounds as the CPU, to
/// `PARITY_X_M` and 1e-4 of the energy. A sheet folding onto itself is chaotic, so elsewhere it
/// may part from the CPU as far as the CPU parts from itself when its start moves by one f32
/// step (an H100 ended 0.2 m from the CPU on cloth-fold, with its contact energy 10% apart).
#[test]
fn gpu_matches_cpu_with_mass_contact() {
    if !gpu_available() {
        return;
    }
    for (name, integrator, frames) in [
        ("pile", Integrator::SemiImplicit, 40),
        ("pile", Integrator::Verlet, 20),
        ("pile", Integrator::Rk4, 15),
        ("cloth-fold", Integrator::SemiImplicit, 40),
    ] {
        let (model, dt) = scene_model(name);
        let substeps = (1.0 / (60.0 * dt)).round() as u32;
        let (worst, c, g) = run_both(&model, integrator, dt, frames, substeps);
        let (ec, eg) = (c.energies, g.energies);
        let (spread_x, spread_e) = nudged_spread(&model, integrator, dt, frames, substeps);
        let exact = common::parity::gpu_rounds_as_the_cpu();
        println!(
            "{name} {integrator}: |Δx| {worst:.2e} m (nudged CPU starts {spread_x:.2e}); contact energy CPU {:.6e} J, GPU {:.6e} J; dissipated CPU {:.6e} J, GPU {:.6e} J",
            ec.contact_j,
            eg.contact_j,
            ec.ledger.dissipated_j(),
            eg.ledger.dissipated_j()
        );
        let allowed_x = if exact {
            PARITY_X_M
        } else {
            PARITY_X_M.max(spread_x)
        };
        assert!(
            worst <= allowed_x,
            "{name} {integrator}: GPU positions differ from the CPU by {worst:.3e} m (nudged CPU starts by {spread_x:.3e})"
        );
        assert!(
            ec.ledger.contact_j > 1e-3,
            "{name} {integrator}: no contact happened ({} J dissipated)",
            ec.ledger.contact_j
        );
        let scale = ec.total_j().abs().max(1e-3);
        let what = ["contact energy", "kinetic energy", "dissipated"];
        for (((what, a), b), spread) in what
            .iter()
            .zip(aggregates(&c))
            .zip(aggregates(&g))
            .zip(spread_e)
        {
            let allowed = if exact {
                1e-4 * scale
            } else {
                (1e-4 * scale).max(spread)
            };
            assert!(
                (a - b).abs() <= allowed,
                "{name} {integrator}: {what} {a} J on the CPU, {b} J on the GPU (nudged CPU starts {spread} J apart)"
            );
        }
    }
}

/// The pair potential on the GPU (mass_contact_energy at snapshot time) equals the CPU's in a
/// state where many pairs are pressed together: the pile mid-impact.
#[test]
fn gpu_contact_energy_matches_the_cpu_mid_impact() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("pile");
    let (mut cpu, mut gpu) = cpu_and_gpu(&model, Step::new(Integrator::SemiImplicit, dt));
    let mut best = (0.0f64, 0.0f64);
    run_pair((&mut cpu, &mut gpu), (30, 40), &mut |c, g| {
        if c.energies.contact_j > best.0 {
            best = (c.energies.contact_j, g.energies.contact_j);
        }
    });
    println!(
        "pile: peak contact energy CPU {:.6e} J, GPU {:.6e} J",
        best.0, best.1
    );
    assert!(
        best.0 > 1e-2,
        "the cubes never pressed together ({} J)",
        best.0
    );
    assert!(
        (best.0 - best.1).abs() <= 1e-4 * best.0,
        "contact energy {} J on the CPU, {} J on the GPU",
        best.0,
        best.1
    );
}

#[test]
fn gpu_runs_with_mass_contact_are_bit_identical() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("pile");
    let run = || {
        let mut gpu = ok(GpuBackend::new(
            model.clone(),
            Step::new(Integrator::SemiImplicit, dt),
            None,
        ));
        for _ in 0..25 {
            ok(gpu.advance(40));
        }
        ok(gpu.state())
    };
    let (a, b) = (run(), run());
    let bytes = |v: &[Vec3]| bytemuck::cast_slice::<Vec3, u8>(v).to_vec();
    assert!(
        bytes(&a.x) == bytes(&b.x) && bytes(&a.v) == bytes(&b.v),
        "two GPU runs differ"
    );
    assert_eq!(a.ledger, b.ledger);
    assert!(a.ledger.contact_j > 1e-3, "no contact happened");
}

/// A cloud of free masses (no springs) in a box, with mass–mass contact.
fn cloud_model(n: usize, extent_m: f32, radius_m: f32, seed: u64) -> Arc<Model> {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((s >> 40) as f32) / ((1u64 << 24) as f32) - 0.5
    };
    let mut mb = ModelBuilder::new();
    for _ in 0..n {
        mb.mass(
            Vec3::new(next(), next(), next()) * extent_m,
            Vec3::ZERO,
            0.01,
            false,
        );
    }
    mb.effects(Effects {
        self_collision: Some(MassContact {
            radius_m,
            contact: ContactModel {
                stiffness_n_per_m: 100.0,
                friction: 0.0,
                damping_ratio: 0.5,
            },
            within_bodies: true,
        }),
        ..Effects::default()
    });
    Arc::new(mb.build())
}

/// The GPU's hash grid (count, multi-level prefix sum, scatter, per-bucket sort) is the CPU's
/// counting sort exactly: bucket starts and sorted masses, for a table of 8 scan blocks and for
/// one of 512 (more block sums than one workgroup scans at once, so grid_scan_sums carries
/// across chunks).
#[test]
fn gpu_hash_grid_equals_the_cpu_grid() {
    if !gpu_available() {
        return;
    }
    for (n, extent, radius) in [(1000usize, 0.5f32, 0.02f32), (40_000, 1.5, 0.01)] {
        let model = cloud_model(n, extent, radius, n as u64);
        let table = hooke::physics::table_size(n);
        // The lists' grid: cells one reach wide.
        let reach = hooke::physics::neighbour_reach_m(radius);
        let mut cpu = hooke::cpu::MassGrid::with_inv_cell(n, 1.0 / reach);
        cpu.build(&model.initial.x);
        let mut gpu = ok(GpuBackend::new(
            model.clone(),
            Step::new(Integrator::SemiImplicit, 1e-3),
            None,
        ));
        let Some(hooke::gpu::GridReadBack {
            cell_start: starts,
            sorted,
        }) = ok(gpu.mass_grid())
        else {
            panic!("no grid on the GPU");
        };
        assert_eq!(starts.len(), table as usize + 1);
        assert_eq!(
            starts[table as usize], n as u32,
            "the grand total is the mass count"
        );
        let crowded = (0..table as usize)
            .filter(|&b| starts[b + 1] - starts[b] > 1)
            .count();
        assert!(
            crowded > 10,
            "{n} masses: only {crowded} buckets hold several"
        );
        let first_bad = starts.iter().zip(&cpu.cell_start).position(|(a, b)| a != b);
        assert_eq!(first_bad, None, "{n} masses: bucket starts differ");
        assert_eq!(sorted, cpu.sorted, "{n} masses: sorted masses differ");
        println!(
            "{n} masses: {table} buckets ({} scan blocks), {crowded} holding several masses: GPU grid = CPU grid",
            table / hooke::physics::SCAN_BLOCK
        );
    }
}

/// A cloud packed so densely that most masses have more masses within reach than a GPU list
/// holds (those walk the grid they were listed from instead): frame by frame, as the cloud
/// bursts apart, the GPU matches the CPU, whose lists have no limit (bit for bit on lavapipe).
#[test]
fn gpu_masses_past_their_list_slots_match_the_cpu() {
    if !gpu_available() {
        return;
    }
    let radius = 0.02;
    let model = cloud_model(400, 0.14, radius, 5);
    let Some(c) = model.effects.self_collision else {
        panic!("no mass contact");
    };
    let lists = hooke::cpu::Neighbours::built_at(&model, &c, &model.initial.x);
    let slots = hooke::gpu::NEIGHBOUR_SLOTS as usize;
    let past = (0..model.mass_count())
        .filter(|&i| lists.of(i).len() > slots)
        .count();
    assert!(
        past > 100,
        "only {past} masses have more than {slots} in reach"
    );
    let (worst, c, g) = run_both(&model, Integrator::SemiImplicit, 1e-4, 10, 20);
    println!("{past} of 400 masses past the slots: |Δx| {worst:.2e} m");
    assert!(
        worst <= PARITY_X_M,
        "GPU positions differ from the CPU by {worst:.3e} m"
    );
    assert!(c.energies.ledger.contact_j > 1e-3, "no contact happened");
    assert!(
        (c.energies.contact_j - g.energies.contact_j).abs() <= 1e-4 * c.energies.total_j().abs(),
        "contact energy {} J on the CPU, {} J on the GPU",
        c.energies.contact_j,
        g.energies.contact_j
    );
}

/// Above `ONE_GROUP_BUILD_MASSES` the GPU builds its lists in a pass per phase instead of in one
/// workgroup: on a cloud of 4 500 masses (a few past their slots) it matches the CPU as well.
#[test]
fn gpu_lists_built_pass_by_pass_match_the_cpu() {
    if !gpu_available() {
        return;
    }
    let n = 4500;
    assert!(n > hooke::gpu::ONE_GROUP_BUILD_MASSES);
    let model = cloud_model(n, 0.6, 0.02, 11);
    let (worst, c, _) = run_both(&model, Integrator::SemiImplicit, 1e-4, 4, 20);
    println!("{n} masses: |Δx| {worst:.2e} m");
    assert!(
        worst <= PARITY_X_M,
        "GPU positions differ from the CPU by {worst:.3e} m"
    );
    assert!(c.energies.ledger.contact_j > 1e-4, "no contact happened");
}

/// The GPU rebuilds its neighbour lists only once a mass has moved past the limit: over
/// cloth-fold's first second (falling, landing, folding), about one build in seven of its 2,400
/// force evaluations (fewer later), and more than the first.
#[test]
fn gpu_neighbour_lists_are_rebuilt_only_when_stale() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("cloth-fold");
    let mut gpu = ok(GpuBackend::new(
        model.clone(),
        Step::new(Integrator::SemiImplicit, dt),
        None,
    ));
    let evaluations = 2400;
    ok(gpu.advance(evaluations));
    let Some(builds) = ok(gpu.neighbour_builds()) else {
        panic!("no neighbour lists on the GPU");
    };
    println!("{builds} builds in {evaluations} force evaluations");
    assert!(
        builds > 1 && builds * 4 < evaluations,
        "{builds} builds in {evaluations} evaluations"
    );
}
