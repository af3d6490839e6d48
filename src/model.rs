//! The static model a backend steps: masses, springs, the per-mass CSR adjacency the force gather
//! walks, pins and effects. Built from a validated [`Scene`] or, for tests and examples, by hand
//! with [`ModelBuilder`].

use glam::Vec3;

use crate::scene::{self, Scene};
use crate::state::State;

/// A damped Hooke spring between masses `a` and `b`. Same layout as `Spring` in
/// `shaders/common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Spring {
    pub a: u32,
    pub b: u32,
    pub rest_m: f32,
    pub stiffness_n_per_m: f32,
    pub damping_n_s_per_m: f32,
}

/// One entry of a mass's adjacency: the spring and the mass at its other end.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Neighbor {
    pub spring: u32,
    pub other: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpringKindTag {
    Structural,
    Shear,
    Bending,
    /// Added by hand through [`ModelBuilder::spring`].
    Custom,
}

impl SpringKindTag {
    pub fn name(self) -> &'static str {
        match self {
            SpringKindTag::Structural => "structural",
            SpringKindTag::Shear => "shear",
            SpringKindTag::Bending => "bending",
            SpringKindTag::Custom => "custom",
        }
    }
}

/// Contact response of one collider, in the form the force evaluation uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactModel {
    pub stiffness_n_per_m: f32,
    pub friction: f32,
    /// Damping ratio ζ of the contact spring that yields the scene's coefficient of restitution e
    /// for a single mass: e = exp(-ζπ / sqrt(1 - ζ²)). Damping per mass is `2ζ sqrt(k m)`.
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

/// Inverse of the restitution of a linear spring-damper impact, e = exp(-ζπ/√(1-ζ²)).
pub fn damping_ratio_for_restitution(e: f32) -> f32 {
    if e <= 0.0 {
        return 1.0;
    }
    let l = f64::from(e).ln();
    (-l / (std::f64::consts::PI * std::f64::consts::PI + l * l).sqrt()) as f32
}

/// Largest damping ratio a mass–mass contact is given: restitution below the ≈0.05 this yields
/// behaves as 0.05, since a stronger damper would shorten the stable step of explicit schemes.
pub const MAX_PAIR_DAMPING_RATIO: f32 = 2.0;

/// Damping ratio ζ at which a penalty spring-damper that can only push gives restitution `e`.
/// Such a contact lets go early, as soon as its damper would start to pull (spring + damper ≤ 0),
/// so it bounces more than the free spring-damper of [`damping_ratio_for_restitution`] (e = 0.1
/// there bounces at 0.25). Found by bisection on the dimensionless impact x'' = −x − 2ζx',
/// x(0) = 0, x'(0) = 1, integrated by RK4 until the push ends; its exit speed falls as ζ grows.
pub fn damping_ratio_for_pushing_restitution(e: f32) -> f32 {
    if e >= 1.0 {
        return 0.0;
    }
    let bounce = |z: f64| -> f64 {
        let push = |x: f64, v: f64| (x + 2.0 * z * v).max(0.0);
        let h = 1e-3;
        let (mut x, mut v) = (0.0f64, 1.0f64);
        // The push lasts less than a period of the undamped spring (2π): bounded loop.
        for _ in 0..(8.0 / h) as usize {
            let (k1x, k1v) = (v, -push(x, v));
            let (k2x, k2v) = (
                v + 0.5 * h * k1v,
                -push(x + 0.5 * h * k1x, v + 0.5 * h * k1v),
            );
            let (k3x, k3v) = (
                v + 0.5 * h * k2v,
                -push(x + 0.5 * h * k2x, v + 0.5 * h * k2v),
            );
            let (k4x, k4v) = (v + h * k3v, -push(x + h * k3x, v + h * k3v));
            x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            if x <= 0.0 || x + 2.0 * z * v <= 0.0 {
                break;
            }
        }
        -v
    };
    let target = f64::from(e.max(0.0));
    let (mut lo, mut hi) = (0.0f64, f64::from(MAX_PAIR_DAMPING_RATIO));
    if bounce(hi) >= target {
        return MAX_PAIR_DAMPING_RATIO;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if bounce(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)) as f32
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundCollider {
    pub height_m: f32,
    pub contact: ContactModel,
    /// Penetration past which the post-step safeguard projects a mass back out.
    pub max_depth_m: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereCollider {
    pub center_m: Vec3,
    pub velocity_m_per_s: Vec3,
    pub radius_m: f32,
    pub contact: ContactModel,
    pub max_depth_m: f32,
}

impl SphereCollider {
    /// Centre at time `t` on its scripted path.
    pub fn center_at(&self, t: f64) -> Vec3 {
        self.center_m + self.velocity_m_per_s * t as f32
    }
}

/// Mass–mass contact: each mass is a sphere of `radius_m`; a pair closer than `2 · radius_m` is
/// pushed apart by `contact` along the line between them. The contact's damping ratio acts with
/// the pair's reduced mass μ = m_a m_b / (m_a + m_b): damping `2ζ sqrt(k μ)` per pair, so that a
/// pair's impact keeps the scene's restitution whatever the two masses are (ζ from
/// [`damping_ratio_for_pushing_restitution`]).
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
    pub spheres: Vec<SphereCollider>,
    pub self_collision: Option<MassContact>,
}

impl Effects {
    pub fn has_contact(&self) -> bool {
        self.ground.is_some() || !self.spheres.is_empty()
    }
}

/// A named group of masses and the springs between them.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyInfo {
    pub name: String,
    pub grid: Vec<u32>,
    pub masses: std::ops::Range<u32>,
    pub springs: std::ops::Range<u32>,
}

/// Compressed sparse rows: `entries[offsets[i]..offsets[i + 1]]` are the springs of mass `i`, in
/// increasing spring order (the order the force gather sums in, on CPU and GPU alike).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Adjacency {
    pub offsets: Vec<u32>,
    pub entries: Vec<Neighbor>,
}

impl Adjacency {
    pub fn build(mass_count: usize, springs: &[Spring]) -> Self {
        let mut counts = vec![0u32; mass_count + 1];
        for s in springs {
            counts[s.a as usize + 1] += 1;
            counts[s.b as usize + 1] += 1;
        }
        for i in 0..mass_count {
            counts[i + 1] += counts[i];
        }
        let offsets = counts;
        let mut fill = offsets.clone();
        let mut entries = vec![
            Neighbor {
                spring: 0,
                other: 0
            };
            2 * springs.len()
        ];
        for (si, s) in springs.iter().enumerate() {
            for (me, other) in [(s.a, s.b), (s.b, s.a)] {
                let slot = &mut fill[me as usize];
                entries[*slot as usize] = Neighbor {
                    spring: si as u32,
                    other,
                };
                *slot += 1;
            }
        }
        Self { offsets, entries }
    }

    pub fn of(&self, mass: usize) -> &[Neighbor] {
        &self.entries[self.offsets[mass] as usize..self.offsets[mass + 1] as usize]
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub bodies: Vec<BodyInfo>,
    pub mass_kg: Vec<f32>,
    /// 0 for pinned masses: they feel forces but never move.
    pub inv_mass: Vec<f32>,
    pub springs: Vec<Spring>,
    pub spring_kind: Vec<SpringKindTag>,
    pub adjacency: Adjacency,
    pub effects: Effects,
    pub initial: State,
    /// Index into `bodies` of each mass (mass–mass contact between bodies only asks it).
    pub mass_body: Vec<u32>,
}

impl Model {
    pub fn mass_count(&self) -> usize {
        self.mass_kg.len()
    }
    pub fn spring_count(&self) -> usize {
        self.springs.len()
    }
    pub fn pinned_count(&self) -> usize {
        self.inv_mass.iter().filter(|&&w| w == 0.0).count()
    }
    pub fn springs_of_kind(&self, kind: SpringKindTag) -> usize {
        self.spring_kind.iter().filter(|&&k| k == kind).count()
    }
    /// The body that mass `i` belongs to, and its index within that body.
    pub fn body_of_mass(&self, i: u32) -> Option<(&BodyInfo, u32)> {
        self.bodies
            .iter()
            .find(|b| b.masses.contains(&i))
            .map(|b| (b, i - b.masses.start))
    }
}

/// Builds a [`Model`] mass by mass and spring by spring.
#[derive(Debug, Default)]
pub struct ModelBuilder {
    bodies: Vec<BodyInfo>,
    mass_kg: Vec<f32>,
    pinned: Vec<bool>,
    x: Vec<Vec3>,
    v: Vec<Vec3>,
    springs: Vec<Spring>,
    kinds: Vec<SpringKindTag>,
    effects: Effects,
}

impl ModelBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a mass and returns its index.
    pub fn mass(&mut self, position: Vec3, velocity: Vec3, mass_kg: f32, pinned: bool) -> u32 {
        self.mass_kg.push(mass_kg);
        self.pinned.push(pinned);
        self.x.push(position);
        self.v.push(if pinned { Vec3::ZERO } else { velocity });
        (self.mass_kg.len() - 1) as u32
    }

    /// Adds a spring whose rest length is the current distance between its ends.
    pub fn spring(
        &mut self,
        a: u32,
        b: u32,
        stiffness_n_per_m: f32,
        damping_n_s_per_m: f32,
    ) -> u32 {
        let rest = self.x[a as usize].distance(self.x[b as usize]);
        self.spring_with_rest(
            a,
            b,
            rest,
            stiffness_n_per_m,
            damping_n_s_per_m,
            SpringKindTag::Custom,
        )
    }

    pub fn spring_with_rest(
        &mut self,
        a: u32,
        b: u32,
        rest_m: f32,
        stiffness_n_per_m: f32,
        damping_n_s_per_m: f32,
        kind: SpringKindTag,
    ) -> u32 {
        self.springs.push(Spring {
            a,
            b,
            rest_m,
            stiffness_n_per_m,
            damping_n_s_per_m,
        });
        self.kinds.push(kind);
        (self.springs.len() - 1) as u32
    }

    fn body_spring_start(&self) -> usize {
        self.bodies.last().map_or(0, |b| b.springs.end as usize)
    }

    /// Sort springs `first..` by (lower, higher) mass index, keeping each spring's kind with it.
    fn sort_springs_from(&mut self, first: usize) {
        let mut order: Vec<usize> = (first..self.springs.len()).collect();
        let key = |s: &Spring| (s.a.min(s.b), s.a.max(s.b));
        order.sort_by_key(|&i| key(&self.springs[i]));
        let springs: Vec<Spring> = order.iter().map(|&i| self.springs[i]).collect();
        let kinds: Vec<SpringKindTag> = order.iter().map(|&i| self.kinds[i]).collect();
        self.springs.truncate(first);
        self.kinds.truncate(first);
        self.springs.extend(springs);
        self.kinds.extend(kinds);
    }

    pub fn effects(&mut self, effects: Effects) -> &mut Self {
        self.effects = effects;
        self
    }

    /// Groups everything added since the previous body under a name.
    pub fn end_body(&mut self, name: &str, grid: Vec<u32>) {
        let m0 = self.bodies.last().map_or(0, |b| b.masses.end);
        let s0 = self.bodies.last().map_or(0, |b| b.springs.end);
        self.bodies.push(BodyInfo {
            name: name.to_owned(),
            grid,
            masses: m0..self.mass_kg.len() as u32,
            springs: s0..self.springs.len() as u32,
        });
    }

    pub fn build(mut self) -> Model {
        if self.bodies.last().map_or(0, |b| b.masses.end) as usize != self.mass_kg.len() {
            let n = self.mass_kg.len() as u32;
            self.end_body("body", vec![n]);
        }
        let inv_mass = self
            .mass_kg
            .iter()
            .zip(&self.pinned)
            .map(|(&m, &p)| if p { 0.0 } else { 1.0 / m })
            .collect();
        let adjacency = Adjacency::build(self.mass_kg.len(), &self.springs);
        let mut mass_body = vec![0u32; self.mass_kg.len()];
        for (k, b) in self.bodies.iter().enumerate() {
            mass_body[b.masses.start as usize..b.masses.end as usize].fill(k as u32);
        }
        Model {
            mass_body,
            bodies: self.bodies,
            mass_kg: self.mass_kg,
            inv_mass,
            springs: self.springs,
            spring_kind: self.kinds,
            adjacency,
            effects: self.effects,
            initial: State::new(self.x, self.v),
        }
    }
}

/// Grid offsets of each spring kind, one per pair (the positive half of each direction).
fn kind_offsets(kind: SpringKindTag) -> &'static [[i32; 3]] {
    match kind {
        SpringKindTag::Structural => &[[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        SpringKindTag::Shear => &[
            [1, 1, 0],
            [1, -1, 0],
            [1, 0, 1],
            [1, 0, -1],
            [0, 1, 1],
            [0, 1, -1],
            [1, 1, 1],
            [1, 1, -1],
            [1, -1, 1],
            [1, -1, -1],
        ],
        SpringKindTag::Bending => &[[2, 0, 0], [0, 2, 0], [0, 0, 2]],
        SpringKindTag::Custom => &[],
    }
}

/// Build the model of a validated scene.
pub fn build(scene: &Scene) -> Model {
    let mut mb = ModelBuilder::new();
    let mut min_spacing = f32::INFINITY;
    for body in &scene.bodies {
        min_spacing = min_spacing.min(body.spacing_m);
        let dim = body.grid.len();
        let n = [
            body.grid[0],
            body.grid.get(1).copied().unwrap_or(1),
            body.grid.get(2).copied().unwrap_or(1),
        ];
        let default_axes = [Vec3::X, Vec3::Y, Vec3::Z];
        let axes: Vec<Vec3> = match &body.axes {
            Some(a) => a.iter().map(|v| Vec3::from(*v).normalize()).collect(),
            None => default_axes[..dim].to_vec(),
        };
        let axis = |a: usize| axes.get(a).copied().unwrap_or(Vec3::ZERO);
        let count = n[0] * n[1] * n[2];
        let m = body.mass_kg / count as f32;
        let origin = Vec3::from(body.origin_m);
        let vel = Vec3::from(body.velocity_m_per_s);
        let index = |i: u32, j: u32, k: u32| i + n[0] * (j + n[1] * k);
        let pinned: std::collections::HashSet<u32> = body
            .pins
            .iter()
            .map(|p| {
                index(
                    p[0],
                    p.get(1).copied().unwrap_or(0),
                    p.get(2).copied().unwrap_or(0),
                )
            })
            .collect();
        let base = mb.mass_kg.len() as u32;
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    let p = origin
                        + body.spacing_m
                            * (i as f32 * axis(0) + j as f32 * axis(1) + k as f32 * axis(2));
                    mb.mass(p, vel, m, pinned.contains(&index(i, j, k)));
                }
            }
        }
        let kinds = [
            (SpringKindTag::Structural, body.springs.structural),
            (SpringKindTag::Shear, body.springs.shear),
            (SpringKindTag::Bending, body.springs.bending),
        ];
        for (tag, params) in kinds {
            let Some(params) = params else { continue };
            for off in kind_offsets(tag) {
                // Skip offsets that move along axes this grid does not have.
                if off.iter().enumerate().any(|(a, &o)| a >= dim && o != 0) {
                    continue;
                }
                for k in 0..n[2] {
                    for j in 0..n[1] {
                        for i in 0..n[0] {
                            let (ti, tj, tk) = (
                                i as i64 + off[0] as i64,
                                j as i64 + off[1] as i64,
                                k as i64 + off[2] as i64,
                            );
                            if ti < 0
                                || tj < 0
                                || tk < 0
                                || ti >= n[0] as i64
                                || tj >= n[1] as i64
                                || tk >= n[2] as i64
                            {
                                continue;
                            }
                            let a = base + index(i, j, k);
                            let b = base + index(ti as u32, tj as u32, tk as u32);
                            let rest = mb.x[a as usize].distance(mb.x[b as usize]);
                            mb.spring_with_rest(
                                a,
                                b,
                                rest,
                                params.stiffness_n_per_m,
                                params.damping_n_s_per_m,
                                tag,
                            );
                        }
                    }
                }
            }
        }
        // Order the body's springs by the masses they join, kinds interleaved, so that a mass's
        // springs (and its neighbours') sit close together in memory for the force passes.
        let first = mb.body_spring_start();
        mb.sort_springs_from(first);
        mb.end_body(&body.name, body.grid.clone());
    }
    // A fast mass may sink a little into a collider before the penalty force turns it round; the
    // post-step safeguard only acts past half a grid spacing (a quarter radius for spheres), so it
    // never fights the penalty contact in ordinary motion but stops any tunnelling.
    let skin = 0.5 * min_spacing;
    let e = &scene.effects;
    mb.effects(Effects {
        gravity_m_per_s2: e.gravity_m_per_s2.map(Vec3::from),
        air_drag_per_s: e.air_drag_per_s,
        ground: e.ground.as_ref().map(|g| GroundCollider {
            height_m: g.height_m,
            contact: ContactModel::from_scene(g.contact()),
            max_depth_m: skin,
        }),
        spheres: e
            .spheres
            .iter()
            .map(|s| SphereCollider {
                center_m: Vec3::from(s.center_m),
                velocity_m_per_s: Vec3::from(s.velocity_m_per_s),
                radius_m: s.radius_m,
                contact: ContactModel::from_scene(s.contact()),
                max_depth_m: skin.min(0.25 * s.radius_m),
            })
            .collect(),
        self_collision: e.self_collision.as_ref().map(|c| MassContact {
            radius_m: c.radius_m,
            contact: ContactModel {
                stiffness_n_per_m: c.stiffness_n_per_m,
                friction: c.friction,
                damping_ratio: damping_ratio_for_pushing_restitution(c.restitution),
            },
            within_bodies: c.within_bodies,
        }),
    });
    mb.build()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restitution_round_trips_through_damping_ratio() {
        for e in [0.1f32, 0.5, 0.9] {
            let z = f64::from(damping_ratio_for_restitution(e));
            let back = (-z * std::f64::consts::PI / (1.0 - z * z).sqrt()).exp();
            assert!((back - f64::from(e)).abs() < 1e-5, "e={e} back={back}");
        }
        assert_eq!(damping_ratio_for_restitution(1.0), 0.0);
    }

    /// The pushing-only contact needs more damping than the free spring-damper for the same
    /// bounce; both agree at e = 1; the clamp only matters when the damper is strong.
    #[test]
    fn pushing_restitution_needs_more_damping_than_the_free_oscillator() {
        assert_eq!(damping_ratio_for_pushing_restitution(1.0), 0.0);
        let mut last = 0.0;
        for e in [0.9f32, 0.5, 0.3, 0.1] {
            let (free, pushing) = (
                damping_ratio_for_restitution(e),
                damping_ratio_for_pushing_restitution(e),
            );
            assert!(
                pushing > free && pushing > last,
                "e={e}: {pushing} vs {free}"
            );
            last = pushing;
        }
        // At e = 0.9 the damper barely pulls before the spring lets go.
        let (a, b) = (
            damping_ratio_for_restitution(0.9),
            damping_ratio_for_pushing_restitution(0.9),
        );
        assert!((b - a) / a < 0.05, "{a} {b}");
        assert_eq!(
            damping_ratio_for_pushing_restitution(0.0),
            MAX_PAIR_DAMPING_RATIO
        );
    }

    #[test]
    fn adjacency_lists_each_spring_at_both_ends_in_order() {
        let mut mb = ModelBuilder::new();
        let a = mb.mass(Vec3::ZERO, Vec3::ZERO, 1.0, false);
        let b = mb.mass(Vec3::X, Vec3::ZERO, 1.0, false);
        let c = mb.mass(Vec3::Y, Vec3::ZERO, 1.0, false);
        mb.spring(a, b, 1.0, 0.0);
        mb.spring(b, c, 1.0, 0.0);
        mb.spring(a, c, 1.0, 0.0);
        let m = mb.build();
        assert_eq!(
            m.adjacency.of(0),
            &[
                Neighbor {
                    spring: 0,
                    other: 1
                },
                Neighbor {
                    spring: 2,
                    other: 2
                }
            ]
        );
        assert_eq!(
            m.adjacency.of(1),
            &[
                Neighbor {
                    spring: 0,
                    other: 0
                },
                Neighbor {
                    spring: 1,
                    other: 2
                }
            ]
        );
        assert_eq!(
            m.adjacency.of(2),
            &[
                Neighbor {
                    spring: 1,
                    other: 1
                },
                Neighbor {
                    spring: 2,
                    other: 0
                }
            ]
        );
    }
}
