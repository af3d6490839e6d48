//! `compute_energies` and `compute_strain`: what a snapshot logs. Mirrors `shaders/reduce.wgsl`
//! (and, for mass–mass contact, `mass_contact_energy` in `shaders/collide_masses.wgsl`).

use glam::Vec3;

use super::collide_masses::mass_contact_energy;
use super::neighbours::Neighbours;
use crate::model::{Model, Spring, poses_at};
use crate::state::{Energies, State};

/// (|x| − L) / L for every spring as it is now (`springs`: the live ones, whose rest lengths
/// plasticity changes); NaN for a broken spring, which has no strain.
pub fn compute_strain(springs: &[Spring], x: &[Vec3], out: &mut Vec<f32>) {
    out.clear();
    out.extend(springs.iter().map(|s| {
        if s.is_broken() {
            return f32::NAN;
        }
        s.strain(x)
    }));
}

/// Kinetic, elastic, gravitational and contact energy of a state, summed in f64, with the live
/// `springs` (a broken one holds no energy).
pub fn compute_energies(model: &Model, springs: &[Spring], state: &State) -> Energies {
    let (x, v) = (&state.x, &state.v);
    let mut e = Energies {
        ledger: state.ledger,
        ..Energies::default()
    };
    for i in 0..x.len() {
        let m = f64::from(model.mass_kg[i]);
        if model.inv_mass[i] != 0.0 {
            e.kinetic_j += 0.5 * m * f64::from(v[i].length_squared());
        }
        if let Some(g) = model.effects.gravity_m_per_s2 {
            e.gravity_j -= m * f64::from(g.dot(x[i]));
        }
    }
    for s in springs {
        let stretch = f64::from(x[s.a as usize].distance(x[s.b as usize]) - s.rest_m);
        e.elastic_j += 0.5 * f64::from(s.stiffness_n_per_m) * stretch * stretch;
    }
    let fx = &model.effects;
    let poses = poses_at(&fx.colliders, state.time_secs);
    for (i, xi) in x.iter().enumerate() {
        if model.inv_mass[i] == 0.0 {
            continue;
        }
        if let Some(g) = &fx.ground {
            let d = f64::from(g.height_m - xi.y);
            if d > 0.0 {
                e.contact_j += 0.5 * f64::from(g.contact.stiffness_n_per_m) * d * d;
            }
        }
        for (c, pose) in fx.colliders.iter().zip(&poses) {
            if let Some((depth, _)) = c.shape.penetration(pose.position_m, *xi) {
                let d = f64::from(depth);
                e.contact_j += 0.5 * f64::from(c.contact.stiffness_n_per_m) * d * d;
            }
        }
    }
    if let Some(c) = &fx.self_collision {
        let neighbours = Neighbours::built_at(model, c, x);
        e.contact_j += mass_contact_energy(c, &neighbours, x);
    }
    e
}
