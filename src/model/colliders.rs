//! What masses collide with: the ground, moving spheres, boxes and planes, other masses, and the
//! contact response of each, in the form the force evaluation uses.

use std::ops::{Div, Mul, Sub};

use glam::Vec3;

use crate::integrator::AskedEffects;
use crate::laws::contact_law::damping_ratio_for_restitution;
use crate::real::{Real, Vector};
use crate::scene;

/// Contact response of one collider, in the form the force evaluation uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactModel {
    pub stiffness_n_per_m: f32,
    pub friction: f32,
    /// Damping ratio ζ of the contact spring that yields the scene's coefficient of restitution e
    /// for a single mass ([`restitution_of_damping_ratio`]). Damping per mass is `2ζ sqrt(k m)`.
    pub damping_ratio: f32,
}

impl ContactModel {
    pub fn from_scene(c: scene::Contact) -> Self {
        Self {
            stiffness_n_per_m: c.stiffness_n_per_m,
            friction: c.friction,
            damping_ratio: damping_ratio_for_restitution(c.restitution),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundCollider {
    pub height_m: f32,
    pub contact: ContactModel,
    /// Penetration past which the post-step safeguard projects a mass back out.
    pub max_depth_m: f32,
}

/// Where a collider is and how fast it moves at one instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pose {
    pub position_m: Vec3,
    pub velocity_m_per_s: Vec3,
}

/// A collider's scripted motion.
#[derive(Debug, Clone, PartialEq)]
pub enum Path {
    /// From `start_m` at t = 0 at constant velocity (zero for a fixed collider).
    Linear {
        start_m: Vec3,
        velocity_m_per_s: Vec3,
    },
    /// Piecewise linear through (time, position) keys in increasing time; held at the first key
    /// before it and at the last after it.
    Keyframes(Vec<(f64, Vec3)>),
}

impl Path {
    /// Position and velocity at time `t` in f64 (the f64 reference solution uses this).
    pub fn pose_at_f64(&self, t: f64) -> (glam::DVec3, glam::DVec3) {
        match self {
            Path::Linear {
                start_m,
                velocity_m_per_s,
            } => (
                start_m.as_dvec3() + velocity_m_per_s.as_dvec3() * t,
                velocity_m_per_s.as_dvec3(),
            ),
            Path::Keyframes(keys) => {
                let seg = keys.windows(2).find(|w| t < w[1].0);
                match (seg, keys.first(), keys.last()) {
                    (_, Some(first), _) if t <= first.0 => (first.1.as_dvec3(), glam::DVec3::ZERO),
                    (Some(w), _, _) => {
                        let (a, b) = (w[0].1.as_dvec3(), w[1].1.as_dvec3());
                        let v = (b - a) / (w[1].0 - w[0].0);
                        (a + v * (t - w[0].0), v)
                    }
                    (None, _, Some(last)) => (last.1.as_dvec3(), glam::DVec3::ZERO),
                    _ => (glam::DVec3::ZERO, glam::DVec3::ZERO),
                }
            }
        }
    }

    /// Pose at time `t`, evaluated in f64 and rounded once, so both backends (the GPU gets it
    /// from the host in its stage uniform) see exactly the same collider.
    pub fn pose_at(&self, t: f64) -> Pose {
        let (p, v) = self.pose_at_f64(t);
        Pose {
            position_m: p.as_vec3(),
            velocity_m_per_s: v.as_vec3(),
        }
    }

    pub fn is_fixed(&self) -> bool {
        match self {
            Path::Linear {
                velocity_m_per_s, ..
            } => *velocity_m_per_s == Vec3::ZERO,
            Path::Keyframes(keys) => keys.windows(2).all(|w| w[0].1 == w[1].1),
        }
    }
}

/// A collider's solid shape, about its pose's position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    Sphere {
        radius_m: f32,
    },
    /// Axis-aligned.
    Box {
        half_extents_m: Vec3,
    },
    /// Solid on the side opposite the unit normal; the pose's position is a point on it.
    Plane {
        normal: Vec3,
    },
}

impl Shape {
    /// Depth of `x` inside the shape placed at `center`, and the outward unit normal, when inside;
    /// in the precision of the vectors given (f32 for the backends, f64 for the reference).
    /// [`Shape::signed_depth`] where it is positive: what the energies and the post-step
    /// safeguard take.
    #[inline(always)]
    pub fn penetration<V>(&self, center: V, x: V) -> Option<(V::Real, V)>
    where
        V: Vector + Sub<Output = V> + Mul<V::Real, Output = V> + Div<V::Real, Output = V>,
    {
        self.signed_depth(center, x)
            .filter(|&(depth, _)| depth > <V::Real as Real>::ZERO)
    }

    /// Signed depth of `x` in the shape placed at `center` (negative outside: minus the distance
    /// to the surface) and the outward unit normal of the surface point nearest `x`; `None` only
    /// where there is no normal (a sphere's centre). The contact law acts on either side of the
    /// surface (`cpu::law::contact_normal_force`: a fast approach is damped before the touch,
    /// so that the force has no jump there), and outside a box the normal turns round its edges
    /// and corners rather than jumping between faces. Mirrors `signed_depth` in
    /// shaders/common.wgsl, operation for operation.
    #[inline(always)]
    pub fn signed_depth<V>(&self, center: V, x: V) -> Option<(V::Real, V)>
    where
        V: Vector + Sub<Output = V> + Mul<V::Real, Output = V> + Div<V::Real, Output = V>,
    {
        let zero = <V::Real as Real>::ZERO;
        let one = <V::Real as Real>::ONE;
        let of_vec = <V::Real as Real>::of_vec;
        let r = x - center;
        match *self {
            Shape::Sphere { radius_m } => {
                let dist = <V::Real as Real>::length(r);
                let depth = <V::Real as Real>::of(radius_m) - dist;
                (dist > zero).then(|| (depth, r / dist))
            }
            Shape::Box { half_extents_m } => {
                let q = <V::Real as Real>::abs(r) - of_vec(half_extents_m);
                let [qx, qy, qz] = <V::Real as Real>::components(q);
                if qx > zero || qy > zero || qz > zero {
                    // Outside: the nearest surface point is on a face, an edge or a corner.
                    let [rx, ry, rz] = <V::Real as Real>::components(r);
                    let out = |q: V::Real, r: V::Real| {
                        let q = q.max(zero);
                        if r < zero { -q } else { q }
                    };
                    let away =
                        <V::Real as Real>::of_components([out(qx, rx), out(qy, ry), out(qz, rz)]);
                    let dist = <V::Real as Real>::length(away);
                    return Some((-dist, away / dist));
                }
                // Inside: the face nearest the point, the axis where it is least deep (first on
                // ties).
                let (axis, gap) = if qx >= qy && qx >= qz {
                    (of_vec(Vec3::X), qx)
                } else if qy >= qz {
                    (of_vec(Vec3::Y), qy)
                } else {
                    (of_vec(Vec3::Z), qz)
                };
                let side = if <V::Real as Real>::dot(r, axis) < zero {
                    -one
                } else {
                    one
                };
                Some((-gap, axis * side))
            }
            Shape::Plane { normal } => {
                let n = of_vec(normal);
                Some((-<V::Real as Real>::dot(r, n), n))
            }
        }
    }
}

/// A solid the masses collide with: a shape on a scripted path.
#[derive(Debug, Clone, PartialEq)]
pub struct Collider {
    pub shape: Shape,
    pub path: Path,
    pub contact: ContactModel,
    /// Penetration past which the post-step safeguard projects a mass back out.
    pub max_depth_m: f32,
}

impl Collider {
    pub fn kind(&self) -> &'static str {
        match self.shape {
            Shape::Sphere { .. } => "sphere",
            Shape::Box { .. } => "box",
            Shape::Plane { .. } => "plane",
        }
    }
}

/// Every collider's pose at one instant.
pub fn poses_at(colliders: &[Collider], t: f64) -> Vec<Pose> {
    colliders.iter().map(|c| c.path.pose_at(t)).collect()
}

/// Mass–mass contact: each mass is a sphere of `radius_m`; a pair closer than `2 · radius_m` is
/// pushed apart by `contact` along the line between them. The contact's damping ratio acts with
/// the pair's reduced mass μ = m_a m_b / (m_a + m_b): damping `2ζ sqrt(k μ)` per pair, so that a
/// pair's impact keeps the scene's restitution whatever the two masses are (ζ from
/// [`damping_ratio_for_restitution`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassContact {
    pub radius_m: f32,
    pub contact: ContactModel,
    /// Masses of one body collide with each other; otherwise only masses of different bodies.
    pub within_bodies: bool,
}

/// The effects present in the model. Absent ones are `None`/empty and cost nothing.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Effects {
    pub gravity_m_per_s2: Option<Vec3>,
    pub air_drag_per_s: Option<f32>,
    pub ground: Option<GroundCollider>,
    /// Spheres, boxes and planes, in the scene's order (spheres, then boxes, then planes).
    pub colliders: Vec<Collider>,
    /// Some body's springs flow plastically.
    pub plasticity: bool,
    /// Some body's springs may break.
    pub tearing: bool,
    pub self_collision: Option<MassContact>,
}

impl AskedEffects for Effects {
    fn mass_contact(&self) -> bool {
        self.self_collision.is_some()
    }
}

impl Effects {
    /// Springs change during the run (plasticity or tearing): a post-step spring pass runs.
    pub fn springs_change(&self) -> bool {
        self.plasticity || self.tearing
    }
    pub fn has_contact(&self) -> bool {
        self.ground.is_some() || !self.colliders.is_empty()
    }
    pub fn has_shape(&self, f: impl Fn(&Shape) -> bool) -> bool {
        self.colliders.iter().any(|c| f(&c.shape))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_keyframed_path_is_piecewise_linear_and_held_at_its_ends() {
        let path = Path::Keyframes(vec![
            (1.0, Vec3::new(0.0, 0.0, 0.0)),
            (3.0, Vec3::new(2.0, 0.0, 0.0)),
            (4.0, Vec3::new(2.0, 1.0, 0.0)),
        ]);
        let at = |t: f64| path.pose_at(t);
        assert_eq!(at(0.0).position_m, Vec3::ZERO);
        assert_eq!(at(0.0).velocity_m_per_s, Vec3::ZERO);
        assert_eq!(at(2.0).position_m, Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(at(2.0).velocity_m_per_s, Vec3::new(1.0, 0.0, 0.0));
        // A key time starts the next segment.
        assert_eq!(at(3.0).position_m, Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(at(3.0).velocity_m_per_s, Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(at(3.5).position_m, Vec3::new(2.0, 0.5, 0.0));
        assert_eq!(at(9.0).position_m, Vec3::new(2.0, 1.0, 0.0));
        assert_eq!(at(9.0).velocity_m_per_s, Vec3::ZERO);
        assert!(!path.is_fixed());
    }

    #[test]
    fn shapes_report_depth_and_outward_normal_inside_only() {
        let sphere = Shape::Sphere { radius_m: 1.0 };
        assert_eq!(
            sphere.penetration(Vec3::ZERO, Vec3::new(0.0, 0.75, 0.0)),
            Some((0.25, Vec3::Y))
        );
        assert_eq!(
            sphere.penetration(Vec3::ZERO, Vec3::new(0.0, 1.5, 0.0)),
            None
        );
        let cube = Shape::Box {
            half_extents_m: Vec3::new(1.0, 0.5, 2.0),
        };
        // Nearest face: −x at 0.2 from it (the y face is 0.3 away, z 1.5).
        let (depth, n) = cube
            .penetration(Vec3::X, Vec3::new(0.2, 0.2, 0.5))
            .unwrap_or_default();
        assert!(
            (depth - 0.2).abs() < 1e-6 && n == Vec3::NEG_X,
            "{depth} {n}"
        );
        assert_eq!(cube.penetration(Vec3::ZERO, Vec3::new(0.0, 0.6, 0.0)), None);
        let floor = Shape::Plane { normal: Vec3::Y };
        assert_eq!(
            floor.penetration(Vec3::Y, Vec3::new(5.0, 0.5, 5.0)),
            Some((0.5, Vec3::Y))
        );
        assert_eq!(floor.penetration(Vec3::Y, Vec3::new(0.0, 1.5, 0.0)), None);
    }

    #[test]
    fn the_reference_precision_finds_the_same_contact() {
        // One formula for both precisions: in f64 the same face and normal, and a depth that
        // differs from the f32 one by rounding only.
        let shapes = [
            Shape::Sphere { radius_m: 0.7 },
            Shape::Box {
                half_extents_m: Vec3::new(0.4, 0.3, 0.9),
            },
            Shape::Plane {
                normal: Vec3::new(0.6, 0.8, 0.0),
            },
        ];
        let center = Vec3::new(0.1, -0.2, 0.3);
        let points = [
            Vec3::new(0.2, 0.0, 0.35),
            Vec3::new(-0.15, -0.3, 0.0),
            Vec3::new(0.1, 0.6, 0.3),
        ];
        let mut contacts = 0;
        for shape in shapes {
            for x in points {
                let single = shape.penetration(center, x);
                let double = shape.penetration(center.as_dvec3(), x.as_dvec3());
                match (single, double) {
                    (Some((d32, n32)), Some((d64, n64))) => {
                        contacts += 1;
                        assert!((f64::from(d32) - d64).abs() < 1e-6, "{shape:?} {x}");
                        assert!((n32.as_dvec3() - n64).length() < 1e-6, "{shape:?} {x}");
                    }
                    (None, None) => {}
                    other => panic!("{shape:?} at {x}: {other:?}"),
                }
            }
        }
        assert!(contacts >= 5, "only {contacts} of the points were inside");
    }
}
