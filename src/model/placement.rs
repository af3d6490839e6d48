//! Where bodies start, checked before anything steps: a body wholly inside a collider, or below
//! the ground by more than its own size, would be thrown out by its contact springs at once (a
//! jello started 5 m under the ground booked 7.6e5 J of contact energy in its first frame).
//! Bodies that start resting on a collider or the ground, as the built-in scenes do, pass.

use glam::Vec3;

use super::colliders::poses_at;
use super::system::Model;

/// A body that starts where no scene means it to.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Buried {
    #[error(
        "body '{body}' starts {depth_m:.3} m below the ground (its top at {top_m:.3} m, the \
         ground at {ground_m:.3} m), more than its own size: its contact would throw it out \
         at once; move its origin_m above the ground"
    )]
    UnderGround {
        body: String,
        depth_m: f32,
        top_m: f32,
        ground_m: f32,
    },
    #[error(
        "body '{body}' starts wholly inside collider {collider} (every mass deeper in it than \
         contact allows): its \
         contact would throw it out at once; move the body's origin_m or the collider"
    )]
    InsideCollider { body: String, collider: usize },
}

/// The first body that starts buried in the ground or inside a collider.
pub fn buried(model: &Model) -> Option<Buried> {
    let x = &model.initial.x;
    let poses = poses_at(&model.effects.colliders, 0.0);
    for b in &model.bodies {
        let masses = &x[b.masses.start as usize..b.masses.end as usize];
        if masses.is_empty() {
            continue;
        }
        let (lo, hi) = masses.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        if let Some(g) = &model.effects.ground {
            let size = (hi - lo).max_element();
            let depth = g.height_m - hi.y;
            if depth > size.max(g.max_depth_m) {
                return Some(Buried::UnderGround {
                    body: b.name.clone(),
                    depth_m: depth,
                    top_m: hi.y,
                    ground_m: g.height_m,
                });
            }
        }
        for (k, (c, pose)) in model.effects.colliders.iter().zip(&poses).enumerate() {
            // Deeper than the safeguard allows, so a flat cloth laid on a collider, touching it
            // at every mass, is not inside it.
            let inside = |p: &Vec3| {
                c.shape
                    .penetration(pose.position_m, *p)
                    .is_some_and(|(depth, _)| depth > c.max_depth_m)
            };
            if masses.iter().all(inside) {
                return Some(Buried::InsideCollider {
                    body: b.name.clone(),
                    collider: k,
                });
            }
        }
    }
    None
}
