//! Building a [`Model`] by hand, mass by mass and spring by spring (tests, examples, and the
//! scene builder).

use glam::Vec3;

use crate::laws::spring_kind::SpringKindTag;
use crate::state::State;

use super::colliders::Effects;
use super::springs::{Adjacency, NO_LIMITS, Spring, SpringLimits};
use super::system::{BodyInfo, BodyShape, Model};

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

    /// Masses added so far.
    pub(super) fn mass_count(&self) -> u32 {
        self.mass_kg.len() as u32
    }

    pub(super) fn position(&self, mass: u32) -> Vec3 {
        self.x[mass as usize]
    }

    pub(super) fn body_spring_start(&self) -> usize {
        self.bodies.last().map_or(0, |b| b.springs.end as usize)
    }

    /// Sort springs `first..` by (lower, higher) mass index, keeping each spring's kind with it.
    pub(super) fn sort_springs_from(&mut self, first: usize) {
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
    pub fn end_body(&mut self, name: &str, shape: BodyShape) {
        let m0 = self.bodies.last().map_or(0, |b| b.masses.end);
        let s0 = self.bodies.last().map_or(0, |b| b.springs.end);
        self.bodies.push(BodyInfo {
            name: name.to_owned(),
            shape,
            masses: m0..self.mass_kg.len() as u32,
            springs: s0..self.springs.len() as u32,
        });
    }

    pub fn build(mut self) -> Model {
        if self.bodies.last().map_or(0, |b| b.masses.end) as usize != self.mass_kg.len() {
            let n = self.mass_kg.len() as u32;
            self.end_body("body", BodyShape::Grid(vec![n]));
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
