//! Springs as the backends store them, and the per-mass adjacency the force gather walks.

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

    /// (|x_b − x_a| − L) / L with the masses at `x`: what the recording colours, the divergence
    /// message names and `compute_strain` (CPU and WGSL) computes. A zero rest length divides by
    /// the least positive f32 instead of by zero, as the shader does.
    #[inline]
    pub fn strain(&self, x: &[glam::Vec3]) -> f32 {
        let len = x[self.a as usize].distance(x[self.b as usize]);
        (len - self.rest_m) / self.rest_m.max(f32::MIN_POSITIVE)
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

/// Limits of a spring that neither yields nor breaks.
pub const NO_LIMITS: SpringLimits = SpringLimits {
    yield_strain: f32::INFINITY,
    relax: 0.0,
    break_strain: f32::INFINITY,
    creep_per_s: 0.0,
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelBuilder;
    use glam::Vec3;

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
