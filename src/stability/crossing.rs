//! The step at which a mass can cross a collider's middle between two steps: a limit of every
//! integrator, the implicit ones included, which no mode of the springs shows.
//!
//! A collider's contact pushes a mass inside it out through the nearest surface. A mass that
//! moves, relative to a sphere, farther than its radius in one step (or than a box's smallest
//! half extent) can land past the middle, and is then pushed out of the far side, with energy
//! from nowhere: the springs it hangs from are torn through the solid. On the built-in scenes
//! this is what ends implicit Euler's and BDF2's stable range where bodies meet spheres: the
//! jello struck by a sphere at 1.5 m/s (docs/stability.md).
//!
//! The speed is bounded from the scene: the collider's own largest speed along its path, plus
//! the fastest a mass can meet it, from its start speed and its fall under gravity from its
//! start to the collider's bottom (or the ground, where that is higher). Speed the springs pass
//! from mass to mass (a whip) or that another collider gives is not in the bound, so this holds
//! as far as `hooke bench stability` measures it, not as a theorem.

use glam::{DVec3, Vec3};

use crate::model::{Collider, Model, Path, Shape};

/// The crossing step of the collider that binds first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// The largest step that keeps every mass within that collider's half-thickness of where
    /// it was, relative to the collider.
    pub dt_secs: f64,
    /// The collider's index (spheres, then boxes, then planes).
    pub collider: usize,
    pub kind: &'static str,
    /// The radius of a sphere, the smallest half extent of a box.
    pub half_thickness_m: f64,
    /// The bound on a mass's speed relative to the collider.
    pub speed_m_per_s: f64,
}

impl Crossing {
    /// The collider of the model whose crossing step is least, where one has a finite one.
    pub fn of(model: &Model) -> Option<Crossing> {
        let fx = &model.effects;
        let g = fx.gravity_m_per_s2.map_or(DVec3::ZERO, |g| g.as_dvec3());
        let up = if g.length() > 0.0 {
            -g.normalize()
        } else {
            DVec3::ZERO
        };
        // The ground (y = its height) holds the masses: none falls past it where gravity is
        // straight down it (elsewhere the bound leaves it out, and is only looser).
        let floor = fx
            .ground
            .filter(|_| up == DVec3::Y)
            .map(|gr| f64::from(gr.height_m));
        fx.colliders
            .iter()
            .enumerate()
            .filter_map(|(n, c)| {
                let half = half_thickness_m(&c.shape)?;
                let bottom = lowest_m(c, up);
                let bottom = floor.map_or(bottom, |f| bottom.max(f));
                let speed =
                    path_speed_m_per_s(&c.path) + fastest_mass_m_per_s(model, g, up, bottom);
                (speed > 0.0).then(|| Crossing {
                    dt_secs: half / speed,
                    collider: n,
                    kind: c.kind(),
                    half_thickness_m: half,
                    speed_m_per_s: speed,
                })
            })
            .min_by(|a, b| a.dt_secs.total_cmp(&b.dt_secs))
    }
}

impl std::fmt::Display for Crossing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "a mass closing on collider {} (a {}, {:.3} m from its surface to its middle) at up to \
             {:.3} m/s (its start speed and a fall from its start) crosses that middle within a \
             larger step and is pushed out of the far side",
            self.collider, self.kind, self.half_thickness_m, self.speed_m_per_s
        )
    }
}

/// How far a mass must move into the shape to pass its middle; none for a plane, whose solid
/// side has no far side.
fn half_thickness_m(shape: &Shape) -> Option<f64> {
    match *shape {
        Shape::Sphere { radius_m } => Some(f64::from(radius_m)),
        Shape::Box { half_extents_m } => Some(f64::from(half_extents_m.min_element())),
        Shape::Plane { .. } => None,
    }
}

/// The collider's lowest point along `up` over its path's keys (a linear path at its start).
fn lowest_m(c: &Collider, up: DVec3) -> f64 {
    let reach = match c.shape {
        Shape::Sphere { radius_m } => f64::from(radius_m) * up.length(),
        Shape::Box { half_extents_m } => half_extents_m.as_dvec3().dot(up.abs()),
        Shape::Plane { .. } => 0.0,
    };
    let bottom = |centre: Vec3| centre.as_dvec3().dot(up) - reach;
    match &c.path {
        Path::Linear { start_m, .. } => bottom(*start_m),
        Path::Keyframes(keys) => keys
            .iter()
            .map(|k| bottom(k.1))
            .fold(f64::INFINITY, f64::min),
    }
}

/// The collider's largest speed along its path.
fn path_speed_m_per_s(path: &Path) -> f64 {
    match path {
        Path::Linear {
            velocity_m_per_s, ..
        } => f64::from(velocity_m_per_s.length()),
        Path::Keyframes(keys) => keys
            .windows(2)
            .map(|w| (w[1].1 - w[0].1).as_dvec3().length() / (w[1].0 - w[0].0))
            .fold(0.0, f64::max),
    }
}

/// The fastest a movable mass can be on reaching the height `bottom`: its start speed and its
/// fall to there, v² = v₀² + 2 |g| drop.
fn fastest_mass_m_per_s(model: &Model, g: DVec3, up: DVec3, bottom: f64) -> f64 {
    let (x, v) = (&model.initial.x, &model.initial.v);
    (0..model.mass_count())
        .filter(|&i| model.inv_mass[i] != 0.0)
        .map(|i| {
            let drop = (x[i].as_dvec3().dot(up) - bottom).max(0.0);
            (v[i].as_dvec3().length_squared() + 2.0 * g.length() * drop).sqrt()
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sphere_is_crossed_at_its_radius_over_the_closing_speed() {
        // A mass 1.25 m above a fixed sphere's bottom (radius 0.25 m) falls onto it at 5 m/s
        // under 10 m/s²: the step that keeps it within the radius is 0.25 / 5 s.
        let path = Path::Linear {
            start_m: Vec3::new(0.0, 1.0, 0.0),
            velocity_m_per_s: Vec3::ZERO,
        };
        let sphere = Shape::Sphere { radius_m: 0.25 };
        let up = DVec3::Y;
        let c = Collider {
            shape: sphere,
            path: path.clone(),
            contact: crate::model::ContactModel {
                stiffness_n_per_m: 1.0,
                friction: 0.0,
                damping_ratio: 0.0,
            },
            max_depth_m: 0.1,
        };
        assert_eq!(lowest_m(&c, up), 0.75);
        assert_eq!(half_thickness_m(&sphere), Some(0.25));
        assert_eq!(half_thickness_m(&Shape::Plane { normal: Vec3::Y }), None);
        let moving = Path::Keyframes(vec![(0.0, Vec3::ZERO), (2.0, Vec3::new(3.0, 4.0, 0.0))]);
        assert_eq!(path_speed_m_per_s(&moving), 2.5);
        assert_eq!(path_speed_m_per_s(&path), 0.0);
    }
}
