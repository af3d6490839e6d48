//! `project_contacts`: the post-step safeguard. Penalty forces inside the integrator do the real
//! contact work; this only catches a mass that sank deeper than the collider's `max_depth_m` (a
//! fast impact), puts it back at that depth and removes its approach speed, so nothing tunnels.
//! Mirrors `project_contacts` in `shaders/collide.wgsl`.

use glam::Vec3;

use crate::model::Model;
use crate::state::State;

/// Returns the number of masses projected. Removed kinetic energy goes to the contact ledger.
pub fn project_contacts(model: &Model, state: &mut State) -> u32 {
    let e = &model.effects;
    if !e.has_contact() {
        return 0;
    }
    let t = state.time_secs;
    let centers: Vec<Vec3> = e.spheres.iter().map(|s| s.center_at(t)).collect();
    let mut count = 0;
    let mut removed_j = 0.0f64;
    for i in 0..state.x.len() {
        if model.inv_mass[i] == 0.0 {
            continue;
        }
        let m = model.mass_kg[i];
        let (x, v) = (&mut state.x[i], &mut state.v[i]);
        if let Some(g) = &e.ground {
            let depth = g.height_m - x.y;
            if let Some(r) = project(x, v, m, Vec3::Y, depth, g.max_depth_m, Vec3::ZERO) {
                removed_j += r;
                count += 1;
            }
        }
        for (s, &c) in e.spheres.iter().zip(&centers) {
            let r = *x - c;
            let dist = r.length();
            if dist > 0.0
                && let Some(r) = project(
                    x,
                    v,
                    m,
                    r / dist,
                    s.radius_m - dist,
                    s.max_depth_m,
                    s.velocity_m_per_s,
                )
            {
                removed_j += r;
                count += 1;
            }
        }
    }
    state.ledger.contact_j += removed_j;
    count
}

/// Move a mass deeper than `max_depth` back to that depth along `n` and remove its approach speed
/// relative to the collider. Returns the kinetic energy removed, or `None` if it was not too deep.
fn project(
    x: &mut Vec3,
    v: &mut Vec3,
    m: f32,
    n: Vec3,
    depth: f32,
    max_depth: f32,
    collider_v: Vec3,
) -> Option<f64> {
    if depth <= max_depth {
        return None;
    }
    *x += n * (depth - max_depth);
    let vn = (*v - collider_v).dot(n);
    if vn >= 0.0 {
        return Some(0.0);
    }
    let before = 0.5 * m * v.length_squared();
    *v -= vn * n;
    Some(f64::from(before - 0.5 * m * v.length_squared()))
}
