//! `collide_masses` and `mass_contact_energy`: contact between mass points, each a sphere of the
//! scene's radius, found through the neighbour lists ([`Neighbours`]). Mirrors
//! `shaders/collide_masses.wgsl`.
//!
//! Each mass gathers the pairs it is in from its own side, by increasing index of the other
//! mass, so every mass is written by one task and the sums are deterministic. The
//! pair force is always computed with the lower mass index first and negated for the other mass,
//! so the two sides are exact negatives (momentum is conserved up to the rounding of each mass's
//! own sum).

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use super::law::{contact_acts, contact_force, contact_normal_force};
use super::neighbours::Neighbours;
use crate::model::{MassContact, Model};
use crate::physics::{PAIR_STICK_SHARE, pair_onset_sq_m2};

/// Contact force on mass `a` of the pair (a, b) and the power its damping and friction
/// dissipate, or `None` if the contact does not act (`law::contact_acts`: they neither touch
/// nor close fast enough to be damped before touching; or sit exactly on each other, with no
/// normal, or are both pinned). A penalty spring `k (2r − d)` along the line between them,
/// damped on the pair's reduced mass μ = 1 / (w_a + w_b), pushing only; Coulomb friction on
/// their relative sliding, at most [`PAIR_STICK_SHARE`] of what would stop it in one step.
#[inline(always)]
pub fn pair_contact(
    c: &MassContact,
    (xa, va, wa): (Vec3, Vec3, f32),
    (xb, vb, wb): (Vec3, Vec3, f32),
    dt: f32,
) -> Option<(Vec3, f32)> {
    let diameter = 2.0 * c.radius_m;
    let d = xa - xb;
    let len_sq = d.dot(d);
    if len_sq >= pair_onset_sq_m2(c.radius_m) || len_sq == 0.0 || wa + wb == 0.0 {
        return None;
    }
    let dist = len_sq.sqrt();
    let depth = diameter - dist;
    let n = d * (1.0 / dist);
    // The pair's relative motion obeys the one-mass contact with the reduced mass, on from just
    // before the touch where they close fast (`contact_normal_force`).
    let mu = 1.0 / (wa + wb);
    let pushes = contact_normal_force(&c.contact, depth, (va - vb).dot(n), mu);
    if !contact_acts(pushes, depth) {
        return None;
    }
    Some(contact_force(
        &c.contact,
        depth,
        n,
        // No load: each pair sees only the relative motion (the pass runs apart from the rest).
        (va - vb, Vec3::ZERO),
        mu,
        dt,
        PAIR_STICK_SHARE,
    ))
}

/// Sum of the pair forces on mass `i` and its share of the pairs' dissipation: half of each pair's,
/// all of it when the other mass is pinned (a pinned mass does not move, so nothing flows there).
#[inline(always)]
fn contact_on_mass(
    model: &Model,
    c: &MassContact,
    neighbours: &Neighbours,
    x: &[Vec3],
    v: &[Vec3],
    i: usize,
    dt: f32,
) -> (Vec3, f32) {
    let wi = model.inv_mass[i];
    let (xi, vi) = (x[i], v[i]);
    let mut f = Vec3::ZERO;
    let mut dissipated = 0.0f32;
    for &j in neighbours.of(i) {
        let j = j as usize;
        let wj = model.inv_mass[j];
        let (me, other) = ((xi, vi, wi), (x[j], v[j], wj));
        let (first, second) = if i < j { (me, other) } else { (other, me) };
        if let Some((fa, diss)) = pair_contact(c, first, second, dt) {
            if i < j {
                f += fa;
            } else {
                f -= fa;
            }
            dissipated += if wj == 0.0 { diss } else { 0.5 * diss };
        }
    }
    (f, dissipated)
}

/// Add the mass–mass contact forces at (x, v) to the accelerations `acc` (which
/// `compute_forces` has just written); returns the power they dissipate. `neighbours` must hold
/// every pair that can touch at `x` ([`Neighbours::update`]).
pub fn collide_masses(
    model: &Model,
    c: &MassContact,
    neighbours: &Neighbours,
    x: &[Vec3],
    v: &[Vec3],
    dt: f32,
    acc: &mut [Vec3],
) -> f64 {
    let chunk_sum = |(ci, out): (usize, &mut [Vec3])| -> f64 {
        let mut sum = 0.0f64;
        for (k, a) in out.iter_mut().enumerate() {
            let i = ci * CHUNK + k;
            let w = model.inv_mass[i];
            if w == 0.0 {
                continue;
            }
            let (f, dissipated) = contact_on_mass(model, c, neighbours, x, v, i, dt);
            // Added to compute_forces' acceleration, as the GPU adds to its output.
            *a += f * w;
            sum += f64::from(dissipated);
        }
        sum
    };
    if acc.len() >= PARALLEL_MIN_MASSES {
        let partials: Vec<f64> = acc
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(chunk_sum)
            .collect();
        partials.into_iter().sum()
    } else {
        acc.chunks_mut(CHUNK).enumerate().map(chunk_sum).sum()
    }
}

/// Energy stored in the compressed pair springs, ½ k (2r − d)² per touching pair, each counted
/// at its lower mass (pairs of two pinned masses exert nothing and hold nothing). `neighbours`
/// must hold every pair that can touch at `x`.
pub fn mass_contact_energy(c: &MassContact, neighbours: &Neighbours, x: &[Vec3]) -> f64 {
    let k = f64::from(c.contact.stiffness_n_per_m);
    let diameter = 2.0 * c.radius_m;
    let mut e = 0.0f64;
    for (i, &xi) in x.iter().enumerate() {
        for &j in neighbours.of(i) {
            if (j as usize) <= i {
                continue;
            }
            let depth = f64::from(diameter) - f64::from(xi.distance(x[j as usize]));
            if depth > 0.0 {
                e += 0.5 * k * depth * depth;
            }
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::neighbours::tests::contact;
    use crate::model::{Effects, ModelBuilder};

    /// A cluster of overlapping masses of different weights moving every which way: the contact
    /// forces sum to zero (each pair's two sides are exact negatives), and every pair in reach
    /// pushes.
    #[test]
    fn pair_forces_are_antisymmetric_and_conserve_momentum() {
        let mut mb = ModelBuilder::new();
        let mut s = 12345u32;
        let mut next = || {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (s >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        for k in 0..40 {
            let p = Vec3::new(next(), next(), next()) * 0.08;
            let v = Vec3::new(next(), next(), next());
            mb.mass(p, v, 0.01 + 0.001 * k as f32, false);
        }
        let c = contact(0.02);
        mb.effects(Effects {
            self_collision: Some(c),
            ..Effects::default()
        });
        let model = mb.build();
        let (x, v) = (&model.initial.x, &model.initial.v);
        let neighbours = Neighbours::built_at(&model, &c, x);
        let mut total = Vec3::ZERO;
        let mut touching = 0;
        for i in 0..x.len() {
            let (f, _) = contact_on_mass(&model, &c, &neighbours, x, v, i, 1e-3);
            total += f;
            if f != Vec3::ZERO {
                touching += 1;
            }
        }
        assert!(touching > 20, "only {touching} masses touch");
        let scale: f32 = (0..x.len())
            .map(|i| {
                contact_on_mass(&model, &c, &neighbours, x, v, i, 1e-3)
                    .0
                    .length()
            })
            .sum();
        assert!(
            total.length() <= 1e-5 * scale,
            "net contact force {total} (scale {scale})"
        );
    }
}
