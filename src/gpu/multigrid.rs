//! Implicit Euler's multigrid cycle on the GPU (`shaders/multigrid.wgsl`): the coarse levels of
//! `crate::physics::hierarchy` (the CPU's, built once per model) laid out in one buffer of words, their
//! numbers in one of vec4s, a window and bind group per level, and the dispatches of each pass.

use super::bindings::{bind_group, buffers};
use super::buffers::Alloc;
use super::dispatch::Dispatch;
use super::kernels::Kernel::{self, *};
use super::layout::MgLevel;
use super::limits::multigrid_unbound_by;
use super::sizing::groups_for;
use crate::model::Model;
use crate::physics::Preconditioner;
use crate::physics::hierarchy::{COARSEST_NODES, Hierarchy, Rows};

/// Words of a level's record (`MG_RECORD_WORDS` in WGSL) and its fields' places.
const RECORD_WORDS: usize = 16;
const R_NODES: usize = 0;
const R_EDGES: usize = 1;
const R_PARENT: usize = 2;
const R_MEMBERS: usize = 3;
const R_EDGE_SOURCES: usize = 4;
const R_OWN_SOURCES: usize = 5;
const R_INCIDENT: usize = 6;
const R_OWN: usize = 8;
const R_EDGE: usize = 9;
const R_DIAG: usize = 10;
const R_X: usize = 11;
const R_B: usize = 12;
const R_Y: usize = 13;
/// Record 0's fields.
const MG_LEVELS: usize = 0;
const MG_Z0: usize = 1;
const MG_DENSE: usize = 2;
const MG_SOLVED: usize = 3;

/// The coarsest level's inverse: 3 unknowns a node, row-major, four to a vec4, after a flag.
const DENSE_VEC4S: usize = 1 + (3 * COARSEST_NODES) * (3 * COARSEST_NODES) / 4;

/// The hierarchy as the kernels read it: `topology` (records, then rows) and the length of the
/// values buffer in vec4s.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    pub topology: Vec<u32>,
    pub values: usize,
    pub levels: usize,
    /// Each level's nodes and edges, finest first.
    pub sizes: Vec<(usize, usize)>,
}

/// Rows appended to `words`: each row's start as a word index, then the entries (`width`
/// words each, from `entry`). Returns where the starts begin.
fn push_rows<T: Copy>(
    words: &mut Vec<u32>,
    rows: &Rows<T>,
    width: u32,
    entry: impl Fn(T) -> [u32; 2],
) -> u32 {
    let starts = words.len();
    let first = (starts + rows.offsets.len()) as u32;
    words.extend(rows.offsets.iter().map(|o| first + width * o));
    for e in &rows.entries {
        words.extend_from_slice(&entry(*e)[..width as usize]);
    }
    starts as u32
}

/// The CSR entry through which the GPU reads spring `s`'s terms: at a free end, where
/// implicit_rhs_at stores them.
fn spring_entries(model: &Model) -> Vec<u32> {
    let mut entry = vec![u32::MAX; model.spring_count()];
    for i in (0..model.mass_count()).rev() {
        if model.inv_mass[i] == 0.0 {
            continue;
        }
        let start = model.adjacency.offsets[i];
        for (k, nb) in model.adjacency.of(i).iter().enumerate() {
            entry[nb.spring as usize] = start + k as u32;
        }
    }
    entry
}

impl Layout {
    /// The levels of an implicit run of `model` whose CG `preconditioner` is asked for, on an
    /// adapter with `limits`: `None` (block Jacobi) unless it is multigrid, the model has coarse
    /// levels and the adapter can run the cycle (`limits::multigrid_unbound_by`, which `hooke
    /// check` reports). Both paths run it: the per-pass path a dispatch per level and pass, the
    /// one-workgroup step as loops over a level's nodes (`mg_implicit_step`).
    pub fn for_run(
        model: &Model,
        preconditioner: Preconditioner,
        limits: &wgpu::Limits,
    ) -> Option<Self> {
        let wanted = preconditioner == Preconditioner::Multigrid
            && multigrid_unbound_by(model, limits).is_none();
        wanted
            .then(|| Hierarchy::new(model))
            .flatten()
            .map(|h| Self::new(model, &h))
    }

    pub fn new(model: &Model, hierarchy: &Hierarchy) -> Self {
        let levels = hierarchy.levels.len();
        let n = model.mass_count();
        let mut words = vec![0u32; RECORD_WORDS * (levels + 1)];
        // Values: the masses' sweep, the coarsest's inverse, then each level's.
        let mut values = 0usize;
        let mut take = |count: usize| {
            let at = values;
            values += count;
            at as u32
        };
        words[MG_LEVELS] = levels as u32;
        words[MG_Z0] = take(n);
        words[MG_DENSE] = take(DENSE_VEC4S);
        words[MG_SOLVED] = u32::from(hierarchy.solves_coarsest());
        let entries = spring_entries(model);
        let mut sizes = Vec::new();
        for (k, level) in hierarchy.levels.iter().enumerate() {
            let (nodes, edges) = (level.nodes, level.edges.len());
            sizes.push((nodes, edges));
            let mut record = [0u32; RECORD_WORDS];
            record[R_NODES] = nodes as u32;
            record[R_EDGES] = edges as u32;
            record[R_PARENT] = words.len() as u32;
            words.extend_from_slice(&level.parent);
            record[R_MEMBERS] = push_rows(&mut words, &level.members, 1, |m| [m, 0]);
            // On the first level a source is a spring, read through its CSR entry.
            let source = |f: u32| [if k == 0 { entries[f as usize] } else { f }, 0];
            record[R_EDGE_SOURCES] = push_rows(&mut words, &level.edge_sources, 1, source);
            record[R_OWN_SOURCES] = push_rows(&mut words, &level.own_sources, 1, source);
            record[R_INCIDENT] = push_rows(&mut words, &level.incident, 2, |(e, o)| [e, o]);
            record[R_OWN] = take(2 * nodes);
            record[R_EDGE] = take(2 * edges);
            record[R_DIAG] = take(2 * nodes);
            record[R_X] = take(nodes);
            record[R_B] = take(nodes);
            record[R_Y] = take(nodes);
            let at = RECORD_WORDS * (k + 1);
            words[at..at + RECORD_WORDS].copy_from_slice(&record);
        }
        Self {
            topology: words,
            values,
            levels,
            sizes,
        }
    }
}

/// The cycle's buffers and a bind group per level.
pub struct MultigridGroups {
    groups: Vec<wgpu::BindGroup>,
    workgroups: Vec<(u32, u32)>,
    pub levels: u32,
    /// A Newton iteration's passes and a cycle's ([`linearise`], [`cycle`]), made once.
    linearise: Vec<Dispatch>,
    cycle: Vec<Dispatch>,
}

impl MultigridGroups {
    /// The cycle's buffers for `layout`, bound beside the solver's group (`solve`) on
    /// `group_layout`, one group per level.
    pub(super) fn new<'b>(
        a: &mut Alloc<'_>,
        group_layout: &wgpu::BindGroupLayout,
        layout: &Layout,
        solve: impl Fn() -> buffers::Solve<'b>,
        uniform_align: u32,
        max_dim: u32,
    ) -> Self {
        let topology = a.model("multigrid levels", bytemuck::cast_slice(&layout.topology));
        let values = a.zeros("multigrid values", 16 * layout.values.max(1));
        let stride = std::mem::size_of::<MgLevel>().next_multiple_of(uniform_align.max(1) as usize);
        let mut windows = vec![0u8; stride * layout.levels.max(1)];
        for k in 0..layout.levels {
            let w = MgLevel {
                level: (k + 1) as u32,
                _pad: [0; 3],
            };
            windows[k * stride..k * stride + std::mem::size_of::<MgLevel>()]
                .copy_from_slice(bytemuck::bytes_of(&w));
        }
        let windows = a.uniform("multigrid level windows", &windows);
        let groups = (0..layout.levels)
            .map(|k| {
                let level = wgpu::BufferBinding {
                    buffer: &windows,
                    offset: (k * stride) as u64,
                    size: wgpu::BufferSize::new(std::mem::size_of::<MgLevel>() as u64),
                };
                bind_group(
                    a.device,
                    group_layout,
                    &buffers::Multigrid {
                        base: solve(),
                        mg_topology: &topology,
                        mg_values: &values,
                        level,
                    },
                )
            })
            .collect();
        let workgroups = layout
            .sizes
            .iter()
            .map(|&(nodes, edges)| groups_for(nodes.max(edges) as u32, max_dim))
            .collect();
        Self {
            groups,
            workgroups,
            levels: layout.levels as u32,
            linearise: linearise(layout.levels as u32),
            cycle: cycle(layout.levels as u32),
        }
    }

    /// A Newton iteration's passes after cg_begin, and a cycle's.
    pub fn passes(&self) -> (&[Dispatch], &[Dispatch]) {
        (&self.linearise, &self.cycle)
    }

    /// Level `k`'s bind group and workgroups (1 the first coarse level).
    pub fn level(&self, k: u32) -> (Option<&wgpu::BindGroup>, Option<(u32, u32)>) {
        let i = (k as usize).wrapping_sub(1);
        (self.groups.get(i), self.workgroups.get(i).copied())
    }
}

/// A Newton iteration's passes after cg_begin over `levels` coarse levels: each level's blocks,
/// finest first, then the coarsest level's inverse.
pub fn linearise(levels: u32) -> Vec<Dispatch> {
    (1..=levels)
        .flat_map(|k| [on(MgLinearise, k), on(MgInvert, k)])
        .chain([on(MgFactor, levels)])
        .collect()
}

/// A cycle over `levels` coarse levels: the masses' start, down the levels, the coarsest's
/// solve, up the levels, and the masses' end.
pub fn cycle(levels: u32) -> Vec<Dispatch> {
    [on(MgFineDown, 1)]
        .into_iter()
        .chain((1..=levels).map(|k| on(MgRestrict, k)))
        .chain([on(MgSolveCoarsest, levels)])
        .chain((1..levels).rev().map(|k| on(MgProlong, k)))
        .chain([on(MgFineUp, 1)])
        .collect()
}

/// For `hooke check`: a cycle's passes over `levels` coarse levels.
pub fn cycle_text(levels: u32) -> String {
    let name = |k: Kernel| k.name();
    let mut parts = vec![
        name(MgFineDown).to_owned(),
        format!("{} × {levels}", name(MgRestrict)),
        name(MgSolveCoarsest).to_owned(),
    ];
    if levels > 1 {
        parts.push(format!("{} × {}", name(MgProlong), levels - 1));
    }
    parts.push(name(MgFineUp).to_owned());
    parts.join(" → ")
}

fn on(kernel: Kernel, level: u32) -> Dispatch {
    Dispatch {
        level,
        ..Dispatch::at(kernel, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// cloth-64's levels as the kernels read them: every record's rows in range, the first
    /// level's sources CSR entries at a free end, each level's values apart.
    #[test]
    fn the_levels_lay_out_within_their_buffers() {
        let crate::run::prepare::Planned { model, .. } =
            crate::run::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
        let h = Hierarchy::new(&model).expect("a sheet has coarse levels");
        let layout = Layout::new(&model, &h);
        let t = &layout.topology;
        assert_eq!(layout.levels, 4);
        assert_eq!(t[MG_SOLVED], 1);
        for k in 1..=layout.levels {
            let r = &t[RECORD_WORDS * k..RECORD_WORDS * (k + 1)];
            let (nodes, edges) = layout.sizes[k - 1];
            assert_eq!((r[R_NODES] as usize, r[R_EDGES] as usize), (nodes, edges));
            let row_end = |field: usize, rows: usize| t[r[field] as usize + rows] as usize;
            assert!(row_end(R_MEMBERS, nodes) <= t.len());
            assert!(row_end(R_INCIDENT, nodes) <= t.len());
            assert!(r[R_Y] as usize + nodes <= layout.values);
            // Each edge's sources: on the first level, entries whose mass is free.
            let first = t[r[R_EDGE_SOURCES] as usize] as usize;
            let last = row_end(R_EDGE_SOURCES, edges);
            for &s in &t[first..last] {
                if k == 1 {
                    let e = s as usize;
                    let mass = model
                        .adjacency
                        .offsets
                        .partition_point(|&o| o as usize <= e)
                        - 1;
                    assert!(model.inv_mass[mass] != 0.0);
                } else {
                    assert!((s as usize) < layout.sizes[k - 2].1);
                }
            }
        }
    }
}
