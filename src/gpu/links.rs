//! The fused steps' compact springs: one link per CSR entry, `(other | kind << shift, rest)`, and
//! the stiffness and damping of each kind in a uniform table. Eight bytes an entry instead of the
//! general layout's neighbour (8) plus its spring (20, read once per end), which is what brings a
//! fused step's compulsory traffic under 36 B per spring update (BENCHMARKS.md). Valid only while
//! the springs never change: plasticity and tearing keep the general layout.

use super::layout::{MAX_SPRING_KINDS, SpringKinds};
use super::stencils::GridStencils;
use crate::model::Model;

/// Why a model's springs have no compact links.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoLinks {
    /// More distinct (stiffness, damping) pairs than the uniform table holds.
    TooManyKinds(usize),
    /// Too many masses for the index bits the kinds leave.
    TooManyMasses { masses: usize, max: u64 },
}

impl std::fmt::Display for NoLinks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoLinks::TooManyKinds(k) => write!(
                f,
                "{k} distinct spring constants (the fused step's table holds {MAX_SPRING_KINDS})"
            ),
            NoLinks::TooManyMasses { masses, max } => write!(
                f,
                "{masses} masses (the fused step's links index {max} beside the spring kinds)"
            ),
        }
    }
}

/// The links, in CSR order, and their kinds; the grid bodies' stencils, whose masses read no
/// links (when they are every mass, `entries` is one unused link).
pub struct Links {
    pub entries: Vec<[u32; 2]>,
    pub kinds: Box<SpringKinds>,
    /// Where a link's kind starts: `KIND_SHIFT` in WGSL.
    pub kind_shift: u32,
    pub stencils: GridStencils,
}

impl Links {
    pub fn build(model: &Model) -> Result<Self, NoLinks> {
        // Kinds numbered in order of first appearance, so the table is the same every run.
        let mut kind_of_key = std::collections::HashMap::new();
        let mut kinds: Vec<(u32, u32)> = Vec::new();
        let kind_of_spring: Vec<u32> = model
            .springs
            .iter()
            .map(|s| {
                let key = (s.stiffness_n_per_m.to_bits(), s.damping_n_s_per_m.to_bits());
                *kind_of_key.entry(key).or_insert_with(|| {
                    kinds.push(key);
                    kinds.len() as u32 - 1
                })
            })
            .collect();
        if kinds.len() > MAX_SPRING_KINDS {
            return Err(NoLinks::TooManyKinds(kinds.len()));
        }
        let kind_bits = kinds.len().max(2).next_power_of_two().trailing_zeros();
        let kind_shift = 32 - kind_bits;
        let max = 1u64 << kind_shift;
        if model.mass_count() as u64 > max {
            return Err(NoLinks::TooManyMasses {
                masses: model.mass_count(),
                max,
            });
        }
        let stencils = GridStencils::build(model);
        let entries = if stencils.cover(model) {
            vec![[0, 0]]
        } else {
            model
                .adjacency
                .entries
                .iter()
                .map(|nb| {
                    let s = &model.springs[nb.spring as usize];
                    let kind = kind_of_spring[nb.spring as usize];
                    [nb.other | (kind << kind_shift), s.rest_m.to_bits()]
                })
                .collect()
        };
        let mut table = Box::new(SpringKinds::default());
        for (slot, (k, d)) in table.kind.iter_mut().zip(&kinds) {
            *slot = [f32::from_bits(*k), f32::from_bits(*d), 0.0, 0.0];
        }
        Ok(Self {
            entries,
            kinds: table,
            kind_shift,
            stencils,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every link decodes to its CSR entry's other mass and spring constants, as spring_end in
    /// shaders/fused_mass.wgsl decodes it (masses of no grid: a net of springs of three kinds).
    #[test]
    fn links_decode_to_the_springs_they_stand_for() {
        let mut mb = crate::model::ModelBuilder::new();
        for i in 0..7 {
            let a = i as f32;
            mb.mass(
                glam::Vec3::new(a.cos(), a.sin(), 0.1 * a),
                glam::Vec3::ZERO,
                1.0,
                false,
            );
        }
        for (a, b, k, c) in [
            (0, 1, 10.0, 0.1),
            (1, 2, 20.0, 0.0),
            (0, 3, 10.0, 0.1),
            (2, 6, 30.0, 0.2),
            (4, 5, 20.0, 0.0),
            (3, 5, 10.0, 0.1),
        ] {
            mb.spring(a, b, k, c);
        }
        let model = mb.build();
        let links = Links::build(&model).expect("few kinds");
        assert_eq!(links.stencils.masses, 0);
        let mask = (1u32 << links.kind_shift) - 1;
        assert_eq!(links.entries.len(), model.adjacency.entries.len());
        for (link, nb) in links.entries.iter().zip(&model.adjacency.entries) {
            let s = &model.springs[nb.spring as usize];
            let kind = links.kinds.kind[(link[0] >> links.kind_shift) as usize];
            assert_eq!(link[0] & mask, nb.other);
            assert_eq!(f32::from_bits(link[1]).to_bits(), s.rest_m.to_bits());
            assert_eq!(kind[0].to_bits(), s.stiffness_n_per_m.to_bits());
            assert_eq!(kind[1].to_bits(), s.damping_n_s_per_m.to_bits());
        }
    }

    /// A scene of grids alone reads no link: its stencils stand for every mass, and one unused
    /// link is all that is uploaded.
    #[test]
    fn grids_alone_upload_no_links() {
        for name in ["hair", "cloth", "jello"] {
            let toml = crate::scene::BUILT_IN
                .iter()
                .find(|b| b.name == name)
                .map(|b| b.toml)
                .expect("built-in");
            let scene = crate::scene::from_toml(toml, crate::scene::SceneOrigin::Text)
                .expect("valid scene");
            let model = crate::model::build(&scene);
            let links = Links::build(&model).expect("few kinds");
            assert!(links.stencils.cover(&model), "{name}");
            assert_eq!(links.entries.len(), 1, "{name}");
        }
    }

    /// More distinct constants than the table holds: no links, and the count says why.
    #[test]
    fn too_many_kinds_are_refused_with_their_count() {
        let mut mb = crate::model::ModelBuilder::new();
        for i in 0..300 {
            mb.mass(
                glam::Vec3::new(i as f32, 0.0, 0.0),
                glam::Vec3::ZERO,
                1.0,
                false,
            );
        }
        for i in 0..299 {
            mb.spring(i, i + 1, 1.0 + i as f32, 0.0);
        }
        let model = mb.build();
        assert_eq!(Links::build(&model).err(), Some(NoLinks::TooManyKinds(299)));
    }
}
