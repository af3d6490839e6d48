//! `project_contacts`: the post-step safeguard. Penalty forces inside the integrator do the real
//! contact work; this only catches a mass that sank deeper than the collider's `max_depth_m` (a
//! fast impact), puts it back at that depth and removes its approach speed, so nothing tunnels.
//! Mirrors `project_contacts` in `shaders/collide.wgsl`.

use glam::Vec3;

use crate::laws::contact_law::DEEP_SHARE;
use crate::model::{Model, poses_at};
use crate::state::State;

/// What one pass of the safeguard did: the contacts it projected, and of those the ones deeper
/// than `DEEP_SHARE` times their allowed depth (`Projected::deep`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Projected {
    pub count: u32,
    /// Contacts a mass sank past a whole grid spacing (twice the allowed depth, which is half
    /// the finest spacing) within one step: it passed where the layer beneath it was, and
    /// putting it back at the allowed depth flattens the body (a 4 × 4 × 4 jello at 1 000 m/s
    /// ended as one plane). The run stops on these (`solver_watch`).
    pub deep: u32,
}

/// Returns what was projected. The impulse is perfectly inelastic in the collider's
/// frame: ½ m v_n² (relative normal speed) is dissipated into the contact ledger, and the change
/// of kinetic energy plus that is work done by the collider (zero for a static one).
pub fn project_contacts(model: &Model, state: &mut State) -> Projected {
    let e = &model.effects;
    if !e.has_contact() {
        return Projected::default();
    }
    let poses = poses_at(&e.colliders, state.time_secs);
    let mut out = Projected::default();
    let (mut dissipated_j, mut work_j) = (0.0f64, 0.0f64);
    for i in 0..state.x.len() {
        if model.inv_mass[i] == 0.0 {
            continue;
        }
        let m = model.mass_kg[i];
        let (x, v) = (&mut state.x[i], &mut state.v[i]);
        if let Some(g) = &e.ground {
            let depth = g.height_m - x.y;
            if let Some((d, w)) = project(x, v, m, Vec3::Y, depth, g.max_depth_m, Vec3::ZERO) {
                dissipated_j += d;
                work_j += w;
                out.count += 1;
                out.deep += u32::from(depth > DEEP_SHARE * g.max_depth_m);
            }
        }
        for (c, pose) in e.colliders.iter().zip(&poses) {
            if let Some((depth, n)) = c.shape.penetration(pose.position_m, *x)
                && let Some((d, w)) =
                    project(x, v, m, n, depth, c.max_depth_m, pose.velocity_m_per_s)
            {
                dissipated_j += d;
                work_j += w;
                out.count += 1;
                out.deep += u32::from(depth > DEEP_SHARE * c.max_depth_m);
            }
        }
    }
    state.ledger.contact_j += dissipated_j;
    state.ledger.collider_work_j += work_j;
    out
}

/// Move a mass deeper than `max_depth` back to that depth along `n` and remove its approach speed
/// relative to the collider. Returns (energy dissipated, work done by the collider), or `None`
/// if it was not too deep.
fn project(
    x: &mut Vec3,
    v: &mut Vec3,
    m: f32,
    n: Vec3,
    depth: f32,
    max_depth: f32,
    collider_v: Vec3,
) -> Option<(f64, f64)> {
    if depth <= max_depth {
        return None;
    }
    *x += n * (depth - max_depth);
    let vn = (*v - collider_v).dot(n);
    if vn >= 0.0 {
        return Some((0.0, 0.0));
    }
    let before = 0.5 * m * v.length_squared();
    *v -= vn * n;
    let dissipated = 0.5 * m * vn * vn;
    Some((
        f64::from(dissipated),
        f64::from(0.5 * m * v.length_squared() - before + dissipated),
    ))
}
