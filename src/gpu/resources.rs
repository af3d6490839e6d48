//! The simulation's GPU buffers and the bind groups over them: the model's (read-only after
//! upload), the state's, and those of the effects a scene has (plasticity and tearing, mass–mass
//! contact, implicit Euler's solver).

use super::bindings::{Group, bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::colours::{ColourGroups, ColourSetup};
use super::dispatch::{ColourPass, Flow, StateIn, Sweeps};
use super::group_set::GroupSet;
use super::kernels::{Path, Sizes, Threads};
use super::layout::{
    COUNTERS_BYTES, FrameSolve, MassContact, NEIGHBOUR_HEAD, NEIGHBOUR_SLOTS, neighbour_bytes,
};
use super::links::Links;
use super::multigrid::{Layout as MultigridLayout, MultigridGroups};
use super::pipelines::Layouts;
use super::sizing::{WORKGROUP, groups_for};
use super::vbd::vbd_groups;
use super::xpbd::xpbd_groups;
use crate::integrator::{Over, Step};
use crate::model::Model;

/// Workgroup counts of each kind of dispatch.
#[derive(Debug, Clone, Copy)]
pub struct Workgroups {
    pub masses: (u32, u32),
    pub springs: (u32, u32),
    /// Over masses or springs, whichever are more: the energy sums' partials.
    pub energies: (u32, u32),
    /// Mass–mass contact only: over the hash grid's buckets, and one per block of its prefix sum.
    pub buckets: (u32, u32),
    pub scan_blocks: (u32, u32),
    /// Implicit Euler's per-pass kernels (`sizing::solver_groups`).
    pub solver: (u32, u32),
}

impl Workgroups {
    /// `None` for a kernel over one colour: its count is the colour's (`ColourGroups`).
    pub fn of(&self, t: Threads) -> Option<(u32, u32)> {
        Some(match t {
            Threads::Masses => self.masses,
            Threads::Springs => self.springs,
            Threads::Energies => self.energies,
            Threads::Buckets => self.buckets,
            Threads::ScanBlocks => self.scan_blocks,
            Threads::OneGroup => (1, 1),
            Threads::SolverGrid => self.solver,
            Threads::Colour | Threads::Level => return None,
        })
    }

    /// Per-workgroup partial sums of the energy reductions.
    pub fn partial_count(&self) -> u64 {
        u64::from(self.energies.0 * self.energies.1)
    }
}

/// Mass–mass contact's hash grid and neighbour lists, as far as the host reads them.
pub struct GridBuffers {
    /// The bucket starts, then the masses sorted by bucket.
    pub grid_index: wgpu::Buffer,
    pub neighbours: wgpu::Buffer,
    pub table_size: u32,
    pub block_count: u32,
}

/// Implicit Euler's solver (its vectors live in the per-mass scratch, `sums`).
pub struct SolverBuffers {
    /// Two `SolverStatus`es, the `FrameSolve`, then two partial sums per workgroup of the
    /// per-pass kernels' grid.
    pub scratch: wgpu::Buffer,
    /// Where the host reads the `FrameSolve` after a frame (the per-pass path).
    pub status: wgpu::Buffer,
    /// Each CSR entry's spring terms at the Newton iterate.
    pub terms: wgpu::Buffer,
    /// The per-pass path: each buffer a frame changes, and its copy from the frame's start, to
    /// replay the frame from when a budget ran out (`implicit.rs`). Empty on the one-workgroup
    /// path, which has no budgets.
    pub frame_start: Vec<(wgpu::Buffer, wgpu::Buffer)>,
}

/// What a run's buffers and bind groups follow from, beyond its model and step.
#[derive(Clone, Copy)]
pub struct ResourcePlan<'a> {
    /// The bind group layouts of the run's kernels (a group no kernel uses is never made).
    pub layouts: &'a Layouts,
    /// The fused steps' compact springs, for a fused run.
    pub links: Option<&'a Links>,
    /// Implicit Euler's path and the workgroups of its per-pass grid.
    pub implicit: Option<(Path, u32)>,
    /// The multigrid cycle's levels, when its CG takes one.
    pub multigrid: Option<&'a MultigridLayout>,
    /// A third state, C, for the fused steps' stages (`fused_plan::keeps_stage_c`).
    pub stage_c: bool,
}

/// Every buffer a run binds, and the bind groups over them.
pub struct Resources {
    pub x: wgpu::Buffer,
    pub v: wgpu::Buffer,
    /// B: RK stage points, Verlet's drift; where a fused step writes.
    pub xt: wgpu::Buffer,
    pub vt: wgpu::Buffer,
    pub ledger: wgpu::Buffer,
    pub counters: wgpu::Buffer,
    pub strain: wgpu::Buffer,
    pub partials: wgpu::Buffer,
    /// Two, so that one frame's snapshot is read back while the next frame steps.
    pub staging: [wgpu::Buffer; 2],
    /// Bind group 0 of each kernel group; `None` for an effect the scene lacks.
    groups: Vec<Option<wgpu::BindGroup>>,
    /// Bind group 1, by [`StateIn`].
    states: [wgpu::BindGroup; 3],
    /// Bind group 1 of the fused kernels, by [`Flow`]; empty when the run is not fused (C, RK4's
    /// second stage point, exists only for RK4).
    flows: Vec<Option<wgpu::BindGroup>>,
    pub grid: Option<GridBuffers>,
    pub solver: Option<SolverBuffers>,
    /// XPBD's or VBD's colour groups (a run has one integrator).
    pub colours: Option<ColourGroups>,
    /// Implicit Euler's multigrid cycle, when its CG takes one (`gpu/multigrid.rs`).
    pub multigrid: Option<MultigridGroups>,
    pub workgroups: Workgroups,
    /// Bytes of GPU memory held by the buffers above (all but the stage slots').
    pub memory_bytes: u64,
}

impl Resources {
    /// Every buffer `model`'s run as `step` binds, and the bind groups `plan` asks for.
    pub fn new(
        device: &wgpu::Device,
        limits: &wgpu::Limits,
        model: &Model,
        step: Step,
        plan: &ResourcePlan<'_>,
    ) -> Self {
        let ResourcePlan {
            layouts,
            links,
            implicit,
            multigrid,
            stage_c,
        } = *plan;
        let Step {
            integrator,
            dt_secs,
            options,
        } = step;
        let mut a = Alloc { device, bytes: 0 };
        let (n, ns) = (model.mass_count(), model.spring_count());
        let max_dim = limits.max_compute_workgroups_per_dimension;
        let mut workgroups = Workgroups {
            masses: groups_for(n as u32, max_dim),
            springs: groups_for(ns as u32, max_dim),
            energies: groups_for(n.max(ns) as u32, max_dim),
            buckets: (1, 1),
            scan_blocks: (1, 1),
            solver: (implicit.map_or(1, |(_, groups)| groups), 1),
        };
        let b = Bufs::new(&mut a, model, integrator, workgroups.partial_count());
        let mut groups = GroupSet {
            device,
            layouts,
            groups: Group::ALL.iter().map(|_| None).collect(),
        };
        groups.common(&b);
        let released = model
            .effects
            .springs_change()
            .then(|| groups.springs(&mut a, &b, model, dt_secs));
        let solver = implicit.map(|(path, grid)| {
            let mut s = SolverBuffers::new(&mut a, &b, model, &mut groups, grid);
            if path == Path::Passes {
                // BDF2's history lives in the solver's vectors (`sums`), so a replay restores them.
                let history = integrator.scheme().history().then_some(&b.sums);
                let changing = [&b.x, &b.v, &b.ledger, &b.counters]
                    .into_iter()
                    .chain(history)
                    .chain(released.iter().flat_map(|r| [&b.springs, r]));
                s.frame_start = changing
                    .map(|live| (live.clone(), a.copy_of(live, "frame start")))
                    .collect();
            }
            s
        });
        let multigrid = solver
            .as_ref()
            .zip(multigrid)
            .zip(layouts.group(Group::Multigrid))
            .map(|((s, layout), group_layout)| {
                MultigridGroups::new(
                    &mut a,
                    group_layout,
                    layout,
                    || solve_buffers(&b, &s.scratch, &s.terms),
                    limits.min_uniform_buffer_offset_alignment,
                    max_dim,
                )
            });
        // XPBD's or VBD's colour groups, the run's integrator's.
        let colour_setup = |layout, iterations| ColourSetup {
            layout,
            iterations,
            uniform_align: limits.min_uniform_buffer_offset_alignment,
            max_per_dim: max_dim,
        };
        let colours = match integrator.scheme().sweeps().map(|s| s.over) {
            Some(Over::Springs) => layouts.group(Group::XpbdSolve).map(|layout| {
                let setup = colour_setup(layout, options.xpbd_iterations);
                let sweeps_layout = layouts.group(Group::XpbdSweeps);
                let (colours, sweeps) =
                    xpbd_groups(&mut a, &b, model, dt_secs, &setup, sweeps_layout);
                groups.groups[Group::XpbdSweeps as usize] = sweeps;
                colours
            }),
            Some(Over::Masses) => layouts.group(Group::VbdSolve).map(|layout| {
                let setup = colour_setup(layout, options.vbd_iterations);
                let sweeps_layout = layouts.group(Group::VbdSweeps);
                let (colours, sweeps) = vbd_groups(&mut a, &b, model, &setup, sweeps_layout);
                groups.groups[Group::VbdSweeps as usize] = sweeps;
                colours
            }),
            None => None,
        };
        let grid = model.effects.self_collision.map(|c| {
            let grid = GridBuffers::new(&mut a, model, &c, &b, &mut groups);
            workgroups.buckets = groups_for(grid.table_size, max_dim);
            workgroups.scan_blocks = groups_for(grid.block_count * WORKGROUP, max_dim);
            grid
        });
        let staging_size = (16 * n + 16 * n + 4 * ns.max(1)) as u64
            + 48 * workgroups.partial_count()
            + COUNTERS_BYTES;
        let staging = [0, 1].map(|_| a.read_back("staging", staging_size));
        let states = [(&b.x, &b.v), (&b.xt, &b.vt), (&b.x, &b.vt)]
            .map(|(x_in, v_in)| bind_group(device, &layouts.state, &buffers::State { x_in, v_in }));
        let flows = links
            .map(|links| groups.fused(&mut a, &b, model, stage_c, links))
            .unwrap_or_default();
        Self {
            x: b.x,
            v: b.v,
            xt: b.xt,
            vt: b.vt,
            ledger: b.ledger,
            counters: b.counters,
            strain: b.strain,
            partials: b.partials,
            staging,
            groups: groups.groups,
            states,
            flows,
            grid,
            solver,
            colours,
            multigrid,
            workgroups,
            memory_bytes: a.bytes,
        }
    }

    /// Bind group 0 of kernel group `g`; `None` for an effect the scene lacks.
    pub fn group(&self, g: Group) -> Option<&wgpu::BindGroup> {
        self.groups[g as usize].as_ref()
    }

    /// The bind group 0 and workgroups of a kernel over one colour (XPBD's projection, VBD's
    /// block solve); `None` when the run has no colours.
    pub fn colour_pass(&self, pass: ColourPass) -> (Option<&wgpu::BindGroup>, Option<(u32, u32)>) {
        let colours = self.colours.as_ref();
        (
            colours.and_then(|c| c.group(pass)),
            colours.and_then(|c| c.workgroups(pass.colour)),
        )
    }

    /// The bind group 0 and workgroups of a multigrid kernel on coarse level `level`, over
    /// `threads` (its level's nodes and edges, one workgroup, or the solver's grid); `None`
    /// when the run has no cycle.
    pub fn level_pass(
        &self,
        level: u32,
        threads: Threads,
    ) -> (Option<&wgpu::BindGroup>, Option<(u32, u32)>) {
        let Some(mg) = self.multigrid.as_ref() else {
            return (None, None);
        };
        let (group, over_level) = mg.level(level);
        let groups = match threads {
            Threads::Level => over_level,
            other => self.workgroups.of(other),
        };
        (group, groups)
    }

    /// The colour sweeps of a step: XPBD's or VBD's (none for the other integrators).
    pub fn sweeps(&self) -> Sweeps {
        self.colours.as_ref().map(|c| c.sweeps).unwrap_or_default()
    }

    /// Bind group 1 over `s`.
    pub fn state(&self, s: StateIn) -> &wgpu::BindGroup {
        &self.states[s as usize]
    }

    /// A fused kernel's bind group 1 over `f`; `None` when the run has no such flow.
    pub fn flow(&self, f: Flow) -> Option<&wgpu::BindGroup> {
        self.flows.get(f as usize).and_then(Option::as_ref)
    }

    /// The sizes a step's memory traffic depends on.
    pub fn sizes(&self, model: &Model) -> Sizes {
        let grid = self.grid.as_ref().map_or((0, 0), |g| {
            (u64::from(g.table_size), u64::from(g.block_count))
        });
        Sizes::of(model, grid)
    }
}

impl SolverBuffers {
    /// The solver's statuses and frame record, then two partial sums per workgroup of its grid.
    fn new(
        a: &mut Alloc<'_>,
        b: &Bufs,
        model: &Model,
        groups: &mut GroupSet<'_>,
        grid: u32,
    ) -> Self {
        let head = FrameSolve::OFFSET + FrameSolve::SIZE;
        let scratch = a.zeros("solver", (head + 2 * 16 * u64::from(grid)) as usize);
        let status = a.read_back("frame solve", FrameSolve::SIZE);
        // Each CSR entry's spring terms at the Newton iterate (two vec4s), kept for the solve.
        let terms = a.zeros("spring terms", 32 * model.adjacency.entries.len().max(1));
        groups.set(solve_buffers(b, &scratch, &terms));
        Self {
            scratch,
            status,
            terms,
            frame_start: Vec::new(),
        }
    }
}

/// The solver's group over the run's buffers, its status and partials (`scratch`) and its
/// spring terms. The Newton iterate is the xt, vt pair; the solver's vectors live in `sums`.
fn solve_buffers<'b>(
    b: &'b Bufs,
    scratch: &'b wgpu::Buffer,
    terms: &'b wgpu::Buffer,
) -> buffers::Solve<'b> {
    buffers::Solve {
        base: b.forces_model(),
        x: &b.x,
        v: &b.v,
        x_in: &b.xt,
        v_in: &b.vt,
        work: &b.sums,
        ledger: &b.ledger,
        counters: &b.counters,
        scratch,
        terms,
    }
}

impl GridBuffers {
    /// The grid's buffers, and the bind groups of its build (grid.wgsl) and of the pairs
    /// (collide_masses.wgsl).
    fn new(
        a: &mut Alloc<'_>,
        model: &Model,
        c: &crate::model::MassContact,
        b: &Bufs,
        groups: &mut GroupSet<'_>,
    ) -> Self {
        let n = model.mass_count();
        let table_size = crate::physics::table_size(n);
        let block_count = table_size / crate::physics::SCAN_BLOCK;
        let reach = crate::physics::neighbour_reach_m(c.radius_m);
        let moved = crate::physics::neighbour_moved_limit_m(c.radius_m);
        let contact = MassContact {
            radius: c.radius_m,
            // The same f32 as the CPU's grid (`Neighbours::new`), so both bin a mass alike.
            inv_cell: 1.0 / reach,
            table_mask: table_size - 1,
            block_count,
            stiffness: c.contact.stiffness_n_per_m,
            friction: c.contact.friction,
            damping_ratio: c.contact.damping_ratio,
            within_bodies: u32::from(c.within_bodies),
            reach_sq: reach * reach,
            moved_sq: moved * moved,
            list_slots: NEIGHBOUR_SLOTS,
            list_head: NEIGHBOUR_HEAD,
        };
        let contact = a.uniform("mass contact", bytemuck::bytes_of(&contact));
        let bodies = a.model("mass bodies", bytemuck::cast_slice(&model.mass_body));
        let table = table_size as usize;
        let cell_count = a.zeros("cell count", 4 * table);
        let grid_index = a.zeros("grid index", 4 * (table + 1 + n));
        let block_sums = a.zeros("block sums", 4 * block_count as usize);
        let mass_cell = a.zeros("mass cell", 4 * n);
        // Stale from the start: the first evaluation builds the lists.
        let mut words = vec![0u32; (neighbour_bytes(n as u64) / 4) as usize];
        words[0] = 1;
        let neighbours = a.storage(
            "neighbour lists",
            bytemuck::cast_slice(&words),
            super::buffers::COPY,
        );
        groups.set(buffers::Grid {
            params: &b.params,
            contact: &contact,
            cell_count: &cell_count,
            grid_index: &grid_index,
            block_sums: &block_sums,
            mass_cell: &mass_cell,
            neighbours: &neighbours,
        });
        groups.set(buffers::CollideMasses {
            params: &b.params,
            contact: &contact,
            mass: &b.mass,
            mass_body: &bodies,
            grid_index: &grid_index,
            neighbours: &neighbours,
            deriv: &b.deriv,
            partials: &b.partials,
        });
        Self {
            grid_index,
            neighbours,
            table_size,
            block_count,
        }
    }
}
