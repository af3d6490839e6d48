//! The fused steps' grid stencils: a grid body's masses find their springs from their cell and
//! one table of slots (the other end's step across the grid, the spring's rest length and
//! constants), so that a step reads x and v and no link per spring (with a link
//! per spring a step at cloth-1024 moved 214 MB). A body takes its stencil only where the stencil reproduces every one
//! of its masses' CSR entries bit for bit and in order (the order the force gather sums in), so
//! the stencil step is the linked one's arithmetic exactly; other bodies (meshes, bodies past the
//! table's room) keep their links.

use std::collections::BTreeMap;

use super::layout::{
    MAX_STENCIL_BODIES, MAX_STENCIL_SLOTS, StencilBody, StencilSlot, StencilTable,
};
use crate::model::{BodyInfo, Model};

/// The table, and how many masses and CSR entries it covers.
pub struct GridStencils {
    pub table: Box<StencilTable>,
    pub masses: usize,
    pub entries: usize,
}

impl GridStencils {
    pub fn build(model: &Model) -> Self {
        let mut table = Box::new(StencilTable::default());
        let (mut masses, mut entries, mut slots) = (0, 0, 0);
        for body in &model.bodies {
            if table.count as usize == MAX_STENCIL_BODIES {
                break;
            }
            let Some(stencil) = stencil_of(model, body) else {
                continue;
            };
            if slots + stencil.len() > MAX_STENCIL_SLOTS {
                continue;
            }
            let grid = body.grid().unwrap_or(&[]);
            let dim = |a: usize| grid.get(a).copied().unwrap_or(1);
            table.bodies[table.count as usize] = StencilBody {
                first_mass: body.masses.start,
                mass_end: body.masses.end,
                slot_start: slots as u32,
                slot_end: (slots + stencil.len()) as u32,
                dims: [dim(0), dim(1), dim(2), 0],
            };
            table.slots[slots..slots + stencil.len()].copy_from_slice(&stencil);
            table.count += 1;
            slots += stencil.len();
            masses += body.masses.len();
            let (first, end) = (body.masses.start as usize, body.masses.end as usize);
            entries += (model.adjacency.offsets[end] - model.adjacency.offsets[first]) as usize;
        }
        Self {
            table,
            masses,
            entries,
        }
    }

    /// Whether every mass takes its springs from a stencil (the links are then never read).
    pub fn cover(&self, model: &Model) -> bool {
        self.masses == model.mass_count()
    }
}

/// For `hooke check` and the tests: how many bodies and masses of `model` a fused run steps
/// through grid stencils (reading no links).
pub fn stencil_cover(model: &Model) -> (usize, usize) {
    let s = GridStencils::build(model);
    (s.table.count as usize, s.masses)
}

/// A grid body's slots, in increasing order of the index step (the order of a mass's CSR
/// entries: by increasing index of the other mass), or `None` when one table cannot stand for
/// its springs: a spring leaving the body, two springs of one step with other constants, or a
/// mass whose CSR entries differ from its slots on the grid (checked for every mass, so that
/// the stencil's sums are the links' sums, term by term).
fn stencil_of(model: &Model, body: &BodyInfo) -> Option<Vec<StencilSlot>> {
    let grid = body.grid()?;
    let n = [0, 1, 2].map(|a| i64::from(grid.get(a).copied().unwrap_or(1)));
    let first = i64::from(body.masses.start);
    let cell = |m: u32| {
        let local = i64::from(m) - first;
        [local % n[0], (local / n[0]) % n[1], local / (n[0] * n[1])]
    };
    let inside = |m: u32| body.masses.contains(&m);
    // Keyed by the index step, then the cell step: on a narrow grid two cell steps may share an
    // index step ((2, 0, 0) and (-1, 1, 0) when n_x = 3), but never both stay on the grid from
    // one cell, so each mass still meets its springs by increasing index of the other end.
    let mut slots: BTreeMap<(i64, [i64; 3]), StencilSlot> = BTreeMap::new();
    for s in &model.springs[body.springs.start as usize..body.springs.end as usize] {
        if !inside(s.a) || !inside(s.b) {
            return None;
        }
        let (ca, cb) = (cell(s.a), cell(s.b));
        for sign in [1, -1] {
            let d = [0, 1, 2].map(|a| sign * (cb[a] - ca[a]));
            let delta = d[0] + n[0] * (d[1] + n[1] * d[2]);
            let slot = StencilSlot {
                step: [d[0], d[1], d[2], delta].map(|v| i32::try_from(v).unwrap_or(i32::MAX)),
                rest: s.rest_m,
                stiffness: s.stiffness_n_per_m,
                damping: s.damping_n_s_per_m,
                _pad: 0.0,
            };
            let same = |o: &StencilSlot| bytemuck::bytes_of(o) == bytemuck::bytes_of(&slot);
            match slots.get(&(delta, d)) {
                Some(o) if !same(o) => return None,
                Some(_) => {}
                None => {
                    slots.insert((delta, d), slot);
                }
            }
        }
    }
    let slots: Vec<StencilSlot> = slots.into_values().collect();
    let reproduces = body.masses.clone().all(|m| {
        let c = cell(m);
        let mut listed = model.adjacency.of(m as usize).iter().map(|nb| {
            let s = &model.springs[nb.spring as usize];
            (
                i64::from(nb.other),
                s.rest_m,
                s.stiffness_n_per_m,
                s.damping_n_s_per_m,
            )
        });
        let on_grid = slots
            .iter()
            .filter(|s| (0..3).all(|a| (0..n[a]).contains(&(c[a] + i64::from(s.step[a])))));
        let bits = |(o, r, k, d): (i64, f32, f32, f32)| (o, r.to_bits(), k.to_bits(), d.to_bits());
        on_grid
            .map(|s| {
                (
                    i64::from(m) + i64::from(s.step[3]),
                    s.rest,
                    s.stiffness,
                    s.damping,
                )
            })
            .map(bits)
            .eq(listed.by_ref().map(bits))
    });
    reproduces.then_some(slots)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model_of(name: &str) -> Model {
        let toml = crate::scene::BUILT_IN
            .iter()
            .find(|b| b.name == name)
            .map(|b| b.toml)
            .expect("built-in");
        let scene =
            crate::scene::from_toml(toml, crate::scene::SceneOrigin::Text).expect("valid scene");
        crate::model::build(&scene)
    }

    /// Every grid body of the built-in scenes whose springs never change takes a stencil, and
    /// walking its slots from each mass's cell, as spring_end in shaders/fused_mass.wgsl does,
    /// yields exactly the mass's CSR entries, in order.
    #[test]
    fn stencils_reproduce_every_grid_mass_s_springs_in_order() {
        for name in ["hair", "cloth", "jello", "jello-sphere", "cloth-64"] {
            let model = model_of(name);
            let stencils = GridStencils::build(&model);
            let t = &stencils.table;
            let grids = model.bodies.iter().filter(|b| b.grid().is_some()).count();
            assert_eq!(t.count as usize, grids.min(MAX_STENCIL_BODIES), "{name}");
            for body in &t.bodies[..t.count as usize] {
                let d = body.dims.map(|v| v as i32);
                for m in body.first_mass..body.mass_end {
                    let local = (m - body.first_mass) as i32;
                    let cell = [local % d[0], (local / d[0]) % d[1], local / (d[0] * d[1])];
                    let walked: Vec<(u32, u32, u32, u32)> = t.slots
                        [body.slot_start as usize..body.slot_end as usize]
                        .iter()
                        .filter(|s| (0..3).all(|a| (0..d[a]).contains(&(cell[a] + s.step[a]))))
                        .map(|s| {
                            let other = (m as i32 + s.step[3]) as u32;
                            (
                                other,
                                s.rest.to_bits(),
                                s.stiffness.to_bits(),
                                s.damping.to_bits(),
                            )
                        })
                        .collect();
                    let listed: Vec<(u32, u32, u32, u32)> = model
                        .adjacency
                        .of(m as usize)
                        .iter()
                        .map(|nb| {
                            let s = &model.springs[nb.spring as usize];
                            let k = s.stiffness_n_per_m.to_bits();
                            (
                                nb.other,
                                s.rest_m.to_bits(),
                                k,
                                s.damping_n_s_per_m.to_bits(),
                            )
                        })
                        .collect();
                    assert_eq!(walked, listed, "{name}: mass {m}");
                }
            }
        }
    }

    /// A scene of grids alone is covered whole; the hair's five strands are five stencils.
    #[test]
    fn grid_scenes_are_covered_whole() {
        for name in ["hair", "cloth", "jello", "cloth-64"] {
            let model = model_of(name);
            assert!(GridStencils::build(&model).cover(&model), "{name}");
        }
        assert_eq!(GridStencils::build(&model_of("hair")).table.count, 5);
    }
}
