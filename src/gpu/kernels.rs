//! Every GPU kernel, declared once (its row in `kernel_table.rs`). A row names the entry point, the WGSL file it is in, what it
//! binds, how many threads it runs, which runs compile it, its CPU namesake (the function in
//! `src/cpu/` computing the same thing, of the same name) or why it has none, and, for the
//! kernels a step plan holds, the compulsory memory traffic of one dispatch. The `Kernel` enum,
//! the pipelines (`pipelines.rs`) and the dispatch plans (`plan.rs`) follow from it; the build
//! fails if a namesake is missing (`crate::conformance::twins`), and `tests/shaders.rs` checks the table against the WGSL.

use super::bindings::Group;
use super::programs::Program;

/// How many threads a kernel runs: one per mass, per spring, per mass or spring (the energy
/// sums), per bucket of the hash grid, per block of its prefix sum, per spring of one XPBD
/// colour (the dispatch names the colour), one workgroup, or implicit Euler's grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threads {
    Masses,
    Springs,
    Energies,
    Buckets,
    ScanBlocks,
    Colour,
    OneGroup,
    /// Implicit Euler's per-pass kernels: a fixed grid of workgroups striding over the masses
    /// (`sizing::solver_groups`).
    SolverGrid,
    /// The multigrid cycle's kernels over one coarse level: a thread per node and edge (the
    /// dispatch names the level).
    Level,
}

/// How an implicit step runs (`sizing::implicit_path` chooses): the whole step in one workgroup, or a
/// dispatch per pass. It decides which of the solver's kernels a run compiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Path {
    InGroup,
    Passes,
}

/// Which runs compile a kernel (absent effects cost nothing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    Always,
    /// The implicit integrator, a dispatch per pass (larger systems).
    ImplicitPasses,
    /// The implicit integrator, the whole step in one workgroup (small systems), its CG
    /// preconditioned by block Jacobi.
    ImplicitInGroup,
    /// BDF2 a dispatch per pass on a scene with the ground or a collider (its restart test).
    ImplicitRestarts,
    /// The implicit integrator a dispatch per pass, its CG preconditioned by multigrid.
    ImplicitMultigrid,
    /// The implicit integrator in one workgroup, its CG preconditioned by multigrid.
    ImplicitInGroupMultigrid,
    /// Plasticity or tearing.
    SpringsChange,
    /// Mass–mass contact.
    MassContact,
    /// The XPBD integrator.
    Xpbd,
    /// The VBD integrator.
    Vbd,
    /// The fused explicit steps (`fused_plan::ExplicitPath::Fused` or `InGroup`).
    Fused,
    /// A submission's fused steps in one workgroup (`fused_plan::ExplicitPath::InGroup`).
    FusedInGroup,
}

/// A kernel's CPU namesake, or why it has none.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Twin {
    /// Its path under `crate::`, ending in the kernel's own name.
    Cpu(&'static str),
    None(&'static str),
}

/// What the table says of one kernel.
#[derive(Debug)]
pub struct Spec {
    pub entry: &'static str,
    pub program: Program,
    pub group: Group,
    /// Whether it reads a state (x and v) through bind group 1.
    pub reads_state: bool,
    /// Whether the state flows through it: bind group 1 holds the state it reads and the one
    /// it writes, and group 3 the step's end slot (a fused step's projection).
    pub flows: bool,
    /// Whether it runs many steps and reads every step's stage slot: group 3 holds the slots
    /// as words (`StageWords`), beside its first slot in group 2.
    pub all_slots: bool,
    pub threads: Threads,
    pub needs: Needs,
    pub twin: Twin,
}

/// The sizes a dispatch's memory traffic depends on.
#[derive(Debug, Clone, Copy)]
pub struct Sizes {
    pub n: u64,
    pub ns: u64,
    /// Buckets of the hash grid and blocks of its prefix sum.
    pub table: u64,
    pub blocks: u64,
    /// Bytes of the colliders.
    pub colliders: u64,
    /// The masses whose fused steps read their springs as links (the others take a grid
    /// stencil, `stencils.rs`), and their CSR entries.
    pub linked_masses: u64,
    pub linked_entries: u64,
}

impl Sizes {
    /// The sizes of `model`'s run; `(table, blocks)`: its hash grid's, (0, 0) without one.
    pub fn of(model: &crate::model::Model, (table, blocks): (u64, u64)) -> Self {
        let stencils = super::stencils::GridStencils::build(model);
        Self {
            n: model.mass_count() as u64,
            ns: model.spring_count() as u64,
            table,
            blocks,
            colliders: model.effects.colliders.len() as u64
                * std::mem::size_of::<super::layout::Collider>() as u64,
            linked_masses: (model.mass_count() - stencils.masses) as u64,
            linked_entries: (model.adjacency.entries.len() - stencils.entries) as u64,
        }
    }
}

macro_rules! kernels {
    ($(
        $(#[doc = $doc:literal])*
        $variant:ident = $entry:ident in $program:ident {
            group: $group:ident $(+ $state:ident)?,
            threads: $threads:ident,
            needs: $needs:ident,
            cpu: $twin:tt
            $(, bytes: |$z:ident| $bytes:expr)? $(,)?
        }
    )*) => {
        /// A GPU kernel, named as its entry point.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Kernel {
            $($(#[doc = $doc])* $variant,)*
        }

        const SPECS: &[Spec] = &[$(Spec {
            entry: stringify!($entry),
            program: Program::$program,
            group: Group::$group,
            reads_state: kernels!(@state $($state)?),
            flows: kernels!(@flow $($state)?),
            all_slots: kernels!(@slots $($state)?),
            threads: Threads::$threads,
            needs: Needs::$needs,
            twin: kernels!(@twin $entry $twin),
        },)*];

        impl Kernel {
            pub const ALL: &[Kernel] = &[$(Kernel::$variant,)*];

            /// Bytes one dispatch reads and writes, caches assumed to absorb the neighbours'
            /// repeated reads; `None` for kernels outside the step plans (the implicit solve's,
            /// whose count of dispatches varies).
            pub fn bytes(self, sizes: &Sizes) -> Option<u64> {
                match self {
                    $(Kernel::$variant => kernels!(@bytes sizes $(|$z| $bytes)?),)*
                }
            }
        }
    };
    (@state) => { false };
    (@state state) => { true };
    (@state flow) => { false };
    (@flow) => { false };
    (@flow state) => { false };
    (@flow flow) => { true };
    (@flow slots) => { false };
    (@state slots) => { false };
    (@slots) => { false };
    (@slots state) => { false };
    (@slots flow) => { false };
    (@slots slots) => { true };
    (@bytes $sizes:ident) => { None };
    (@bytes $sizes:ident |$z:ident| $bytes:expr) => {{
        let $z: &Sizes = $sizes;
        Some($bytes)
    }};
    (@twin $entry:ident ($($module:ident)::+)) => {
        Twin::Cpu(concat!("cpu", $("::", stringify!($module),)+ "::", stringify!($entry)))
    };
    (@twin $entry:ident $reason:literal) => { Twin::None($reason) };
}

super::kernel_table::kernel_table!(kernels);

impl Kernel {
    pub fn spec(self) -> &'static Spec {
        &SPECS[self as usize]
    }

    pub fn name(self) -> &'static str {
        self.spec().entry
    }
}

/// Every kernel's spec, in table order (for the checks in tests/shaders.rs).
#[doc(hidden)]
pub fn table() -> &'static [Spec] {
    SPECS
}
