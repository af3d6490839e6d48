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

impl Spring {
    /// A broken spring (tearing) has neither stiffness nor damping: it exerts nothing, and the
    /// force passes skip it. Scene springs always have stiffness, so nothing else looks like this.
    #[inline(always)]
    pub fn is_broken(&self) -> bool {
        self.stiffness_n_per_m == 0.0 && self.damping_n_s_per_m == 0.0
    }
}

/// What may happen to one spring during a run: plastic flow past `yield_strain` and breaking
/// past `break_strain` (infinite when the body has no such effect). Same layout as
/// `SpringLimits` in `shaders/common.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SpringLimits {
    pub yield_strain: f32,
    /// Fraction of the way to the yield length the rest length moves in one step:
    /// 1 − exp(−creep_per_s · dt), 0 without plasticity. Set per dt by [`Model::spring_limits`].
    pub relax: f32,
    pub break_strain: f32,
    pub creep_per_s: f32,
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

/// Largest contact damping ratio: more would need a much smaller step (the damper's rate
/// 2ζω grows past the spring's ω), so the least restitution a contact can have is
/// [`MIN_RESTITUTION`].
pub const MAX_CONTACT_DAMPING_RATIO: f64 = 2.0;

/// The restitution at [`MAX_CONTACT_DAMPING_RATIO`], rounded up: `restitution_of_damping_ratio(2.0)`
/// is 0.0478.
pub const MIN_RESTITUTION: f32 = 0.05;

/// Coefficient of restitution of one impact on a penalty contact (spring k, damper 2ζ√(km)) that
/// pushes but never pulls: the contact ends when its force reaches zero, before the spring is
/// back at rest, so the bounce is larger than the linear oscillator's e = exp(−ζπ/√(1−ζ²))
/// (Schwager & Pöschel, Granular Matter 2007). In units of the contact's ω and the impact
/// speed, depth d(t) solves d″ = −d − 2ζd′ from d = 0, d′ = 1; the force d + 2ζd′ vanishes at
/// t*, and the mass leaves at speed |d′(t*)|.
pub fn restitution_of_damping_ratio(z: f64) -> f64 {
    if z <= 0.0 {
        return 1.0;
    }
    if z < 1.0 {
        let w = (1.0 - z * z).sqrt();
        let a = 1.0 - 2.0 * z * z;
        // ω t*: where tan(ωt) = −2ζω / (1 − 2ζ²), in (0, π].
        let wt = if a > 0.0 {
            std::f64::consts::PI - (2.0 * z * w / a).atan()
        } else if a < 0.0 {
            (2.0 * z * w / -a).atan()
        } else {
            std::f64::consts::FRAC_PI_2
        };
        let t = wt / w;
        return ((-z * t).exp() * (wt.cos() - z / w * wt.sin())).abs();
    }
    if z == 1.0 {
        // d = t e^{−t}: the force vanishes at t = 2.
        return (-2.0f64).exp();
    }
    let s = (z * z - 1.0).sqrt();
    let (r1, r2) = (-z + s, -z - s);
    let t = ((1.0 + 2.0 * z * r2) / (1.0 + 2.0 * z * r1)).ln() / (r1 - r2);
    ((r1 * (r1 * t).exp() - r2 * (r2 * t).exp()) / (r1 - r2)).abs()
}

/// The damping ratio whose impact keeps restitution `e` ([`restitution_of_damping_ratio`] is
/// continuous and decreasing, so bisection finds it); `e` at or below [`MIN_RESTITUTION`]'s
/// exact value gives [`MAX_CONTACT_DAMPING_RATIO`] (validation refuses less than 0.05).
pub fn damping_ratio_for_restitution(e: f32) -> f32 {
    let e = f64::from(e);
    if e >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, MAX_CONTACT_DAMPING_RATIO);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if restitution_of_damping_ratio(mid) > e {
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
    /// Depth of `x` inside the shape placed at `center`, and the outward unit normal, when inside.
    /// Mirrors `penetration` in shaders/common.wgsl, operation for operation.
    #[inline(always)]
    pub fn penetration(&self, center: Vec3, x: Vec3) -> Option<(f32, Vec3)> {
        let r = x - center;
        match *self {
            Shape::Sphere { radius_m } => {
                let dist = r.length();
                let depth = radius_m - dist;
                (depth > 0.0 && dist > 0.0).then(|| (depth, r / dist))
            }
            Shape::Box { half_extents_m } => {
                let q = r.abs() - half_extents_m;
                // The face nearest the point: the axis where it is least deep (first on ties).
                let (axis, gap) = if q.x >= q.y && q.x >= q.z {
                    (Vec3::X, q.x)
                } else if q.y >= q.z {
                    (Vec3::Y, q.y)
                } else {
                    (Vec3::Z, q.z)
                };
                let side = if r.dot(axis) < 0.0 { -1.0 } else { 1.0 };
                (gap < 0.0).then(|| (-gap, axis * side))
            }
            Shape::Plane { normal } => {
                let depth = -r.dot(normal);
                (depth > 0.0).then_some((depth, normal))
            }
        }
    }
}

impl Shape {
    /// [`Shape::penetration`] in f64, for the reference solution.
    pub fn penetration_f64(
        &self,
        center: glam::DVec3,
        x: glam::DVec3,
    ) -> Option<(f64, glam::DVec3)> {
        use glam::DVec3;
        let r = x - center;
        match *self {
            Shape::Sphere { radius_m } => {
                let dist = r.length();
                let depth = f64::from(radius_m) - dist;
                (depth > 0.0 && dist > 0.0).then(|| (depth, r / dist))
            }
            Shape::Box { half_extents_m } => {
                let q = r.abs() - half_extents_m.as_dvec3();
                let (axis, gap) = if q.x >= q.y && q.x >= q.z {
                    (DVec3::X, q.x)
                } else if q.y >= q.z {
                    (DVec3::Y, q.y)
                } else {
                    (DVec3::Z, q.z)
                };
                let side = if r.dot(axis) < 0.0 { -1.0 } else { 1.0 };
                (gap < 0.0).then(|| (-gap, axis * side))
            }
            Shape::Plane { normal } => {
                let n = normal.as_dvec3();
                let depth = -r.dot(n);
                (depth > 0.0).then_some((depth, n))
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
    /// Per spring, when some body has plasticity or tearing; empty otherwise.
    pub limits: Vec<SpringLimits>,
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
    /// The springs' limits with the relaxation of one step of `dt_secs` filled in (f32 from f64,
    /// the same on both backends).
    pub fn spring_limits(&self, dt_secs: f64) -> Vec<SpringLimits> {
        self.limits
            .iter()
            .map(|l| SpringLimits {
                relax: if l.creep_per_s > 0.0 {
                    (-(-f64::from(l.creep_per_s) * dt_secs).exp_m1()) as f32
                } else {
                    0.0
                },
                ..*l
            })
            .collect()
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
    limits: Vec<SpringLimits>,
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
        if !self.limits.is_empty() {
            let limits: Vec<SpringLimits> = order.iter().map(|&i| self.limits[i]).collect();
            self.limits.truncate(first);
            self.limits.extend(limits);
        }
    }

    /// Give springs `first..` the same limits (others get none, meaning never yield or break).
    pub fn limit_springs_from(&mut self, first: usize, limits: SpringLimits) {
        self.limits.resize(self.springs.len(), NO_LIMITS);
        for l in &mut self.limits[first..] {
            *l = limits;
        }
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
        if !self.limits.is_empty() {
            self.limits.resize(self.springs.len(), NO_LIMITS);
        }
        let yields = |l: &SpringLimits| l.yield_strain.is_finite();
        self.effects.plasticity = self.limits.iter().any(yields);
        self.effects.tearing = self.limits.iter().any(|l| l.break_strain.is_finite());
        let mut mass_body = vec![0u32; self.mass_kg.len()];
        for (k, b) in self.bodies.iter().enumerate() {
            mass_body[b.masses.start as usize..b.masses.end as usize].fill(k as u32);
        }
        Model {
            limits: self.limits,
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

/// Limits of a spring that neither yields nor breaks.
pub const NO_LIMITS: SpringLimits = SpringLimits {
    yield_strain: f32::INFINITY,
    relax: 0.0,
    break_strain: f32::INFINITY,
    creep_per_s: 0.0,
};

/// Grid offsets of each spring kind, one per pair (the positive half of each direction).
pub fn kind_offsets(kind: SpringKindTag) -> &'static [[i32; 3]] {
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
        if body.plasticity.is_some() || body.tearing.is_some() {
            mb.limit_springs_from(
                first,
                SpringLimits {
                    yield_strain: body.plasticity.map_or(f32::INFINITY, |p| p.yield_strain),
                    relax: 0.0,
                    break_strain: body.tearing.map_or(f32::INFINITY, |t| t.max_strain),
                    creep_per_s: body.plasticity.map_or(0.0, |p| p.creep_per_s),
                },
            );
        }
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
        colliders: colliders(e, skin),
        self_collision: e.self_collision.as_ref().map(|c| MassContact {
            radius_m: c.radius_m,
            contact: ContactModel::from_scene(c.contact()),
            within_bodies: c.within_bodies,
        }),
        ..Effects::default()
    });
    mb.build()
}

fn path_of(center_m: Option<[f32; 3]>, velocity: [f32; 3], keys: &[scene::Keyframe]) -> Path {
    if keys.is_empty() {
        Path::Linear {
            start_m: Vec3::from(center_m.unwrap_or_default()),
            velocity_m_per_s: Vec3::from(velocity),
        }
    } else {
        Path::Keyframes(
            keys.iter()
                .map(|k| (k.time_secs, Vec3::from(k.center_m)))
                .collect(),
        )
    }
}

/// The scene's colliders; `skin` is the largest safeguard depth (half the finest grid spacing).
fn colliders(e: &scene::Effects, skin: f32) -> Vec<Collider> {
    let spheres = e.spheres.iter().map(|s| Collider {
        shape: Shape::Sphere {
            radius_m: s.radius_m,
        },
        path: path_of(s.center_m, s.velocity_m_per_s, &s.keyframes),
        contact: ContactModel::from_scene(s.contact()),
        max_depth_m: skin.min(0.25 * s.radius_m),
    });
    let boxes = e.boxes.iter().map(|b| {
        let h = Vec3::from(b.half_extents_m);
        Collider {
            shape: Shape::Box { half_extents_m: h },
            path: path_of(b.center_m, b.velocity_m_per_s, &b.keyframes),
            contact: ContactModel::from_scene(b.contact()),
            max_depth_m: skin.min(0.25 * h.min_element()),
        }
    });
    let planes = e.planes.iter().map(|p| Collider {
        shape: Shape::Plane {
            normal: Vec3::from(p.normal).normalize(),
        },
        path: Path::Linear {
            start_m: Vec3::from(p.point_m),
            velocity_m_per_s: Vec3::ZERO,
        },
        contact: ContactModel::from_scene(p.contact()),
        max_depth_m: skin,
    });
    spheres.chain(boxes).chain(planes).collect()
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
    fn restitution_round_trips_through_damping_ratio() {
        for e in [0.05f32, 0.1, 0.135, 0.3, 0.5, 0.9] {
            let z = f64::from(damping_ratio_for_restitution(e));
            let back = restitution_of_damping_ratio(z);
            assert!((back - f64::from(e)).abs() < 1e-5, "e={e} back={back}");
        }
        assert_eq!(damping_ratio_for_restitution(1.0), 0.0);
        // Critical damping still bounces back at e^−2 (the contact lets go at t = 2/ω).
        assert!((restitution_of_damping_ratio(1.0) - (-2.0f64).exp()).abs() < 1e-12);
        // Continuous through critical damping, from both sides.
        for z in [1.0 - 1e-6, 1.0 + 1e-6] {
            assert!((restitution_of_damping_ratio(z) - (-2.0f64).exp()).abs() < 1e-5);
        }
        assert!(
            restitution_of_damping_ratio(MAX_CONTACT_DAMPING_RATIO) < f64::from(MIN_RESTITUTION)
        );
    }

    #[test]
    fn restitution_closed_form_matches_an_integrated_impact() {
        // d'' = -max(d + 2ζd', 0) from d = 0, d' = 1, integrated finely with RK4 until it leaves.
        for z in [0.1f64, 0.456, 0.8, 1.5] {
            let f = |d: f64, v: f64| -(d + 2.0 * z * v).max(0.0);
            let (mut d, mut v, h) = (0.0f64, 1.0f64, 1e-5);
            while d >= 0.0 {
                let (k1x, k1v) = (v, f(d, v));
                let (k2x, k2v) = (v + 0.5 * h * k1v, f(d + 0.5 * h * k1x, v + 0.5 * h * k1v));
                let (k3x, k3v) = (v + 0.5 * h * k2v, f(d + 0.5 * h * k2x, v + 0.5 * h * k2v));
                let (k4x, k4v) = (v + h * k3v, f(d + h * k3x, v + h * k3v));
                d += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
            let closed = restitution_of_damping_ratio(z);
            assert!(
                (-v - closed).abs() < 1e-4,
                "ζ = {z}: integrated {}, closed form {closed}",
                -v
            );
        }
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
