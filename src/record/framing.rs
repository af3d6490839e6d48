//! Where the 3D view's eye is: on the bodies and the room they move through, not on everything
//! the view holds (the viewer's own framing takes in the ground grid and every collider, and left
//! a 1.2 m flag a speck seen edge-on). A run opens framed on where its bodies start and the room
//! they are likely to move into; once it ends, its recording is framed on every place they went
//! ([`Visited`]), which is what a recording opened afterwards shows.

use glam::Vec3;

use crate::model::{Model, Shape};

/// The eye's position and what it looks at, in the world's metres (y up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Framing {
    pub eye_m: Vec3,
    pub target_m: Vec3,
}

/// The direction the eye looks from: in front (+z), a little to the right and above, so that a
/// sheet lying flat, a strand hanging and a block on the ground all show depth.
const FROM: Vec3 = Vec3::new(0.25, 0.4, 1.0);

/// The eye's distance in radii of the framed box's bounding sphere: the box, inside that
/// sphere, fills most of the view's height at Rerun's default field of view (about 50°).
const DISTANCE_IN_RADII: f32 = 1.6;

/// Masses sampled a frame for [`Visited`]: enough to follow every body's extent, few enough to
/// cost nothing beside a frame's logging on the largest scenes.
const VISITED_SAMPLES: usize = 4096;

impl Framing {
    /// Before the run: the bodies and the colliders of finite size at the start, with the room
    /// around them that the bodies are likely to move into: a tenth of their size each way
    /// across, at least as tall as they are wide below (a sheet held flat hangs), and down to
    /// the ground where it is within three of their sizes below (a block dropped lands), never
    /// below it. The eye takes in all of that room but looks halfway between it and where the
    /// bodies start: a body that hangs or drapes spends its run in the room's upper part.
    pub fn at_start(model: &Model) -> Option<Self> {
        let (lo, hi) = with_colliders(model, extent(&model.initial.x));
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let start = 0.5 * (lo + hi);
        let size = (hi - lo).max_element();
        let mut low = lo.y.min(hi.y - size);
        if let Some(g) = &model.effects.ground {
            if g.height_m >= hi.y - 3.0 * size {
                low = low.min(g.height_m);
            }
            low = low.max(g.height_m.min(lo.y));
        }
        let across = Vec3::new(0.1 * size, 0.0, 0.1 * size);
        let (lo, hi) = (Vec3::new(lo.x, low, lo.z) - across, hi + across);
        Some(Self::on(lo, hi, 0.5 * (start + 0.5 * (lo + hi))))
    }

    /// After the run: every place the bodies went, and the colliders of finite size at the
    /// start.
    pub fn over_run(model: &Model, visited: &Visited) -> Option<Self> {
        let (lo, hi) = with_colliders(model, visited.extent?);
        (lo.is_finite() && hi.is_finite()).then(|| Self::on(lo, hi, 0.5 * (lo + hi)))
    }

    /// Looking at `target` from [`FROM`], far enough to take in the box `lo`–`hi`.
    fn on(lo: Vec3, hi: Vec3, target_m: Vec3) -> Self {
        let radius = (0.5 * (hi - lo).length()).max(0.05);
        Self {
            eye_m: target_m + FROM.normalize() * DISTANCE_IN_RADII * radius,
            target_m,
        }
    }
}

/// The box every sampled mass has been in over the frames seen so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Visited {
    extent: Option<(Vec3, Vec3)>,
}

impl Visited {
    /// Widens the box by a frame's positions (every k-th mass, and the last).
    pub fn see(&mut self, x: &[Vec3]) {
        let stride = x.len().div_ceil(VISITED_SAMPLES).max(1);
        let sampled = x.iter().step_by(stride).chain(x.last());
        let (lo, hi) = sampled.filter(|p| p.is_finite()).fold(
            self.extent.unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        if lo.cmple(hi).all() {
            self.extent = Some((lo, hi));
        }
    }
}

/// `(lo, hi)` widened by the colliders of finite size where they start.
fn with_colliders(model: &Model, (mut lo, mut hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
    for c in &model.effects.colliders {
        let half = match c.shape {
            Shape::Sphere { radius_m } => Vec3::splat(radius_m),
            Shape::Box { half_extents_m } => half_extents_m,
            Shape::Plane { .. } => continue,
        };
        let at = c.path.pose_at(0.0).position_m;
        (lo, hi) = (lo.min(at - half), hi.max(at + half));
    }
    (lo, hi)
}

/// Lowest and highest corner of a set of points.
pub(super) fn extent(x: &[Vec3]) -> (Vec3, Vec3) {
    x.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_visited_box_grows_with_every_frame_and_skips_what_is_not_finite() {
        let mut v = Visited::default();
        v.see(&[Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        v.see(&[Vec3::new(-1.0, 0.5, 0.0), Vec3::NAN]);
        assert_eq!(
            v.extent,
            Some((Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 2.0, 3.0)))
        );
        // A large frame is sampled, its last mass always among the samples.
        let mut big = vec![Vec3::ZERO; 100_000];
        big[99_999] = Vec3::splat(10.0);
        let mut w = Visited::default();
        w.see(&big);
        assert_eq!(w.extent, Some((Vec3::ZERO, Vec3::splat(10.0))));
    }

    #[test]
    fn the_eye_looks_at_the_box_from_the_front_above_and_right() {
        let f = Framing::on(Vec3::ZERO, Vec3::ONE, Vec3::splat(0.5));
        let d = f.eye_m - f.target_m;
        assert!(d.x > 0.0 && d.y > 0.0 && d.z > d.y, "{d}");
        // Far enough that the box's bounding sphere is inside the view.
        assert!(d.length() > 0.5 * 3f32.sqrt(), "{d}");
    }
}
