//! Every bind group, declared once: each binding's name, access and WGSL type, in binding order.
//! From this table come the WGSL declarations each program is compiled with
//! (`shaders::Program::source`: no WGSL file declares a binding), the bind group layouts
//! (`pipelines.rs`), and for each group a struct of its buffers by binding name, which
//! `resources.rs` fills and [`GroupBuffers::in_order`] lays out in binding order. A binding added
//! here reaches all three; `tests/shaders.rs` checks the table against naga's parse of every
//! program.

/// How a binding is accessed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    Uniform,
    Read,
    ReadWrite,
}

/// One binding of a group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binding {
    /// Its name in WGSL, and its field in the group's buffers.
    pub name: &'static str,
    pub slot: Slot,
    /// A window of a larger buffer at an offset the dispatch gives (the stage slots).
    pub dynamic: bool,
    pub ty: &'static str,
}

impl Binding {
    /// Its WGSL declaration as binding `index` of group `group`.
    pub fn wgsl(&self, group: u32, index: usize) -> String {
        let space = match self.slot {
            Slot::Uniform => "uniform",
            Slot::Read => "storage, read",
            Slot::ReadWrite => "storage, read_write",
        };
        format!(
            "@group({group}) @binding({index}) var<{space}> {}: {};\n",
            self.name, self.ty
        )
    }
}

/// A bind group of `buffers` on `layout`, each at its binding in the table (`bindings.rs`).
pub fn bind_group<'a, G: GroupBuffers<'a>>(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    buffers: &G,
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .in_order()
        .into_iter()
        .enumerate()
        .map(|(i, resource)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource,
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&format!("{:?}", G::GROUP)),
        layout,
        entries: &entries,
    })
}

/// A group's buffers laid out in binding order, for a bind group.
pub trait GroupBuffers<'a> {
    const GROUP: Group;
    fn in_order(&self) -> Vec<wgpu::BindingResource<'a>>;
}

macro_rules! bind_groups {
    ($(
        $(#[doc = $doc:literal])*
        $group:ident @ $index:literal $(= $parent:ident +)? {
            $(
                $(#[doc = $bdoc:literal])*
                $name:ident : $slot:ident $ty:literal
            ),* $(,)?
        }
    )*) => {
        /// A bind group: bind group 0 of each kind of kernel, the state a kernel reads or flows
        /// between (group 1), and the stage slots (groups 2 and 3).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Group {
            $($(#[doc = $doc])* $group,)*
        }

        impl Group {
            pub const ALL: &[Group] = &[$(Group::$group,)*];

            /// Its index in a pipeline's layout.
            pub fn index(self) -> u32 {
                match self {
                    $(Group::$group => $index,)*
                }
            }

            /// The group a group extends: its bindings come first.
            pub fn parent(self) -> Option<Group> {
                match self {
                    $(Group::$group => bind_groups!(@parent $($parent)?),)*
                }
            }

            /// Its bindings, in binding order.
            pub fn bindings(self) -> Vec<Binding> {
                let mut all = self.parent().map_or_else(Vec::new, Group::bindings);
                all.extend(match self {
                    $(Group::$group => vec![$(bind_groups!(@binding $name $slot $ty)),*],)*
                });
                all
            }
        }

        /// Each group's buffers by binding name.
        pub mod buffers {
            use super::{Group, GroupBuffers};

            $(
                $(#[doc = $doc])*
                pub struct $group<'a> {
                    $(pub base: $parent<'a>,)?
                    $($(#[doc = $bdoc])* pub $name: bind_groups!(@field $slot),)*
                }

                impl<'a> GroupBuffers<'a> for $group<'a> {
                    const GROUP: Group = Group::$group;

                    fn in_order(&self) -> Vec<wgpu::BindingResource<'a>> {
                        let base: Vec<wgpu::BindingResource<'a>> =
                            bind_groups!(@base self $($parent)?);
                        base.into_iter()
                            .chain([$(bind_groups!(@resource $slot self.$name)),*])
                            .collect()
                    }
                }
            )*
        }
    };
    (@parent) => { None };
    // The buffers of the group a group extends, first.
    (@base $this:ident) => { Vec::new() };
    (@base $this:ident $parent:ident) => { GroupBuffers::in_order(&$this.base) };
    (@parent $parent:ident) => { Some(Group::$parent) };
    (@binding $name:ident Dynamic $ty:literal) => {
        Binding { name: stringify!($name), slot: Slot::Uniform, dynamic: true, ty: $ty }
    };
    (@binding $name:ident Window $ty:literal) => {
        Binding { name: stringify!($name), slot: Slot::Uniform, dynamic: false, ty: $ty }
    };
    (@binding $name:ident $slot:ident $ty:literal) => {
        Binding { name: stringify!($name), slot: Slot::$slot, dynamic: false, ty: $ty }
    };
    // A whole buffer, or (a stage slot, an XPBD colour) a window of one.
    (@field Dynamic) => { wgpu::BufferBinding<'a> };
    (@field Window) => { wgpu::BufferBinding<'a> };
    (@field $slot:ident) => { &'a wgpu::Buffer };
    (@resource Dynamic $e:expr) => { wgpu::BindingResource::Buffer($e.clone()) };
    (@resource Window $e:expr) => { wgpu::BindingResource::Buffer($e.clone()) };
    (@resource $slot:ident $e:expr) => { $e.as_entire_binding() };
}

bind_groups! {
    /// `compute_forces` (forces.wgsl).
    ForcesModel @ 0 {
        params: Uniform "Params",
        springs: Read "array<Spring>",
        offsets: Read "array<u32>",
        neighbors: Read "array<Neighbor>",
        colliders: Read "array<Collider>",
        /// (mass, inverse mass; 0 when pinned).
        mass: Read "array<vec2<f32>>",
        /// Per mass: [2i] acceleration, [2i+1] ledger rates (damping, drag, contact, collider
        /// work); with IMPLICIT also [2n + 2i], [2n + 2i + 1] the contacts' share of the
        /// implicit system.
        deriv: ReadWrite "array<vec4<f32>>",
    }
    /// The update kernels (integrate.wgsl).
    Integrate @ 0 {
        params: Uniform "Params",
        x: ReadWrite "array<vec4<f32>>",
        v: ReadWrite "array<vec4<f32>>",
        xt: ReadWrite "array<vec4<f32>>",
        vt: ReadWrite "array<vec4<f32>>",
        /// [2i] acceleration, [2i+1] ledger rates, from the last compute_forces.
        deriv: Read "array<vec4<f32>>",
        /// (mass, inverse mass; 0 when pinned): VBD's residual weighs by it.
        mass: Read "array<vec2<f32>>",
        /// Per-mass scratch. RK4 and Verlet: [3i] Σ weighted stage velocities, [3i+1] Σ weighted
        /// accelerations, [3i+2] Σ weighted rates. VBD: [i] the velocity at the last step's
        /// start, [n + g] workgroup g's sums of its residual (vbd_final).
        sums: ReadWrite "array<vec4<f32>>",
        /// Energy that left (damping, drag, contact) or entered (collider work) through each mass.
        ledger: ReadWrite "array<vec4<f32>>",
        /// [1]: u32::MAX − (index of the first step whose state went non-finite or ran away), 0
        /// if none.
        counters: ReadWrite "array<atomic<u32>>",
    }
    /// `project_contacts` (collide.wgsl), dispatched at the step's end slot.
    Collide @ 0 {
        params: Uniform "Params",
        colliders: Read "array<Collider>",
        mass: Read "array<vec2<f32>>",
        x: ReadWrite "array<vec4<f32>>",
        v: ReadWrite "array<vec4<f32>>",
        ledger: ReadWrite "array<vec4<f32>>",
        /// [0] masses projected since the counters were last cleared.
        counters: ReadWrite "array<atomic<u32>>",
    }
    /// `compute_strain`, `compute_energies` (reduce.wgsl).
    Reduce @ 0 {
        params: Uniform "Params",
        springs: Read "array<Spring>",
        colliders: Read "array<Collider>",
        mass: Read "array<vec2<f32>>",
        x: Read "array<vec4<f32>>",
        v: Read "array<vec4<f32>>",
        ledger: Read "array<vec4<f32>>",
        strain: ReadWrite "array<f32>",
        /// Per workgroup: [3g] (kinetic, elastic, gravity, contact), [3g+1] ledger, [3g+2] (max
        /// speed, count of masses with a non-finite state, energy let go by plasticity and
        /// tearing (written by sum_spring_work), 0).
        partials: ReadWrite "array<vec4<f32>>",
    }
    /// Implicit Euler (implicit.wgsl): `compute_forces`' group (its forces at the Newton
    /// iterate, `deriv` then also holding [2n + 2i], [2n + 2i + 1] the contacts), and what the
    /// solve needs; `implicit_step` does the whole step in one dispatch.
    Solve @ 0 = ForcesModel + {
        x: ReadWrite "array<vec4<f32>>",
        v: ReadWrite "array<vec4<f32>>",
        /// The Newton iterate (the state forces_on reads).
        x_in: ReadWrite "array<vec4<f32>>",
        v_in: ReadWrite "array<vec4<f32>>",
        /// The solver's per-mass vectors (block() in common.wgsl).
        work: ReadWrite "array<vec4<f32>>",
        ledger: ReadWrite "array<vec4<f32>>",
        /// [1] the divergence flag (check_state); [2] the most CG iterations of a step since the
        /// last snapshot; [3] the largest residual (an f32's bits: positive floats order as
        /// their bits).
        counters: ReadWrite "array<atomic<u32>>",
        scratch: ReadWrite "Scratch",
        /// Each CSR entry's spring terms at the iterate (spring_terms), stored by
        /// implicit_rhs_at for the solve's products: [2e] (n, h²k + h c), [2e + 1]
        /// (h²k·max(0, 1 − L/l), …).
        terms: ReadWrite "array<vec4<f32>>",
    }
    /// The multigrid cycle (multigrid.wgsl): the solver's group, the coarse levels and their
    /// numbers, and which level the dispatch works on.
    Multigrid @ 0 = Solve + {
        /// Each level's record and rows (`gpu/multigrid.rs`).
        mg_topology: Read "array<u32>",
        /// Each level's blocks and vectors, the masses' sweep from zero and the coarsest
        /// level's inverse.
        mg_values: ReadWrite "array<vec4<f32>>",
        /// This group's level, a window of one buffer holding them all.
        level: Window "MgLevel",
    }
    /// Plasticity and tearing (springs.wgsl).
    Springs @ 0 {
        params: Uniform "Params",
        springs: ReadWrite "array<Spring>",
        limits: Read "array<SpringLimits>",
        x: Read "array<vec4<f32>>",
        /// Elastic energy each spring let go since the last snapshot.
        released: ReadWrite "array<f32>",
        /// compute_energies' partial sums (reduce.wgsl): sum_spring_work fills [3g + 2].z.
        partials: ReadWrite "array<vec4<f32>>",
    }
    /// Mass–mass contact's neighbour lists and their hash grid (grid.wgsl).
    Grid @ 0 {
        params: Uniform "Params",
        contact: Uniform "MassContact",
        /// Masses per bucket while building; grid_scatter counts each back down to zero, which
        /// is where the next build starts.
        cell_count: ReadWrite "array<atomic<u32>>",
        /// The bucket starts (one more than buckets), then the masses sorted by bucket: bucket b
        /// holds [table + 1 + start[b] .. table + 1 + start[b + 1]].
        grid_index: ReadWrite "array<u32>",
        block_sums: ReadWrite "array<u32>",
        /// Bucket of each mass, from grid_count.
        mass_cell: ReadWrite "array<u32>",
        /// [0] stale, [1] builds, then per mass its list's length, position at the build and
        /// list (grid.wgsl).
        neighbours: ReadWrite "array<atomic<u32>>",
    }
    /// `xpbd_sweeps` (xpbd_sweeps.wgsl): XPBD's projection, every sweep over every colour.
    XpbdSweeps @ 0 = XpbdSprings + {
        /// The sweeps, the colours, then where each colour's springs start in colour_order (one
        /// more than colours).
        sweep_plan: Read "array<u32>",
    }
    /// `collide_masses`, `mass_contact_energy` (collide_masses.wgsl): with the state's x and v,
    /// the 8 storage buffers a stage may bind.
    CollideMasses @ 0 {
        params: Uniform "Params",
        contact: Uniform "MassContact",
        mass: Read "array<vec2<f32>>",
        /// Body index of each mass.
        mass_body: Read "array<u32>",
        grid_index: Read "array<u32>",
        /// The lists; these passes clear the stale flag ([0]) once they have read them.
        neighbours: ReadWrite "array<u32>",
        /// compute_forces' output: [2i] acceleration, [2i+1] ledger rates; the pairs are added.
        deriv: ReadWrite "array<vec4<f32>>",
        /// compute_energies' per-workgroup sums (reduce.wgsl): the pair potential is added to
        /// [3g].w.
        partials: ReadWrite "array<vec4<f32>>",
    }
    /// What XPBD's projection reads and writes (xpbd_project.wgsl), which its two groups extend.
    XpbdSprings @ 0 {
        params: Uniform "Params",
        /// The springs as they are now (plasticity and tearing change them).
        springs: Read "array<Spring>",
        constants: Read "array<XpbdSpring>",
        /// Spring indices, colour by colour.
        colour_order: Read "array<u32>",
        mass: Read "array<vec2<f32>>",
        /// Positions at the substep's start.
        x: Read "array<vec4<f32>>",
        /// The substep's displacement (the xt buffer): xpbd_predict writes it, this corrects it.
        dx: ReadWrite "array<vec4<f32>>",
        /// Each spring's multiplier within the substep.
        lambda: ReadWrite "array<f32>",
    }
    /// XPBD's projection of one colour (xpbd.wgsl): a group per colour and kind of sweep.
    XpbdSolve @ 0 = XpbdSprings + {
        /// This group's colour and sweep, a window of one buffer holding them all.
        colour: Window "ColourRange",
    }
    /// What VBD's block solve reads and writes (vbd_mass.wgsl): `compute_forces`' group
    /// (mass_force reads it), the colours' masses, the step's start and the iterate.
    VbdMasses @ 0 = ForcesModel + {
        /// Mass indices, colour by colour.
        colour_order: Read "array<u32>",
        /// The step's start.
        x: Read "array<vec4<f32>>",
        v: Read "array<vec4<f32>>",
        /// The iterate (the xt and vt buffers): vbd_predict writes it, the block solves refine it.
        x_in: ReadWrite "array<vec4<f32>>",
        v_in: ReadWrite "array<vec4<f32>>",
    }
    /// VBD's block solve of one colour (vbd.wgsl), a group per colour.
    VbdSolve @ 0 = VbdMasses + {
        /// This group's colour, a window of one buffer holding them all.
        colour: Window "ColourRange",
    }
    /// `vbd_sweeps` (vbd_sweeps.wgsl): VBD's block solves, every sweep over every colour.
    VbdSweeps @ 0 = VbdMasses + {
        /// The sweeps, the colours, then where each colour's masses start in colour_order (one
        /// more than colours).
        sweep_plan: Read "array<u32>",
    }
    /// The fused steps (fused.wgsl); the state flows through group 1.
    Fused @ 0 {
        params: Uniform "Params",
        kinds: Uniform "SpringKinds",
        /// The grid bodies' stencils (`stencils.rs`): their masses read no links.
        stencils: Uniform "StencilTable",
        offsets: Read "array<u32>",
        links: Read "array<vec2<u32>>",
        colliders: Read "array<Collider>",
        mass: Read "array<vec2<f32>>",
        /// Verlet: [2i] a(x_n) and [2i+1] its rates, kept from the last kick for the next drift.
        deriv: ReadWrite "array<vec4<f32>>",
        /// RK4: [3i] Σ weighted stage velocities, [3i+1] accelerations, [3i+2] rates. Verlet:
        /// [3i] the half-kicked velocity, [3i+2] a(x_n)'s rates.
        sums: ReadWrite "array<vec4<f32>>",
        ledger: ReadWrite "array<vec4<f32>>",
        /// [0] masses projected; [1] the divergence flag (check_state).
        counters: ReadWrite "array<atomic<u32>>",
    }
    /// RK4's middle stages: the fused steps' group, and the step's starting state, which their
    /// stage points start from.
    FusedMid @ 0 = Fused + {
        x_base: Read "array<vec4<f32>>",
        v_base: Read "array<vec4<f32>>",
    }
    /// A submission's Euler or semi-implicit steps in one workgroup (fused_frame.wgsl): the fused
    /// steps' group, and the state, which lives in A (`x_in`, `v_in`, the run's x and v)
    /// between steps and passes through B (`x_out`, `v_out`, its xt and vt) within one.
    FusedFrame @ 0 = Fused + {
        x_in: ReadWrite "array<vec4<f32>>",
        v_in: ReadWrite "array<vec4<f32>>",
        x_out: ReadWrite "array<vec4<f32>>",
        v_out: ReadWrite "array<vec4<f32>>",
    }
    /// The state a force evaluation reads.
    State @ 1 {
        x_in: Read "array<vec4<f32>>",
        v_in: Read "array<vec4<f32>>",
    }
    /// The state a fused step reads, and the one it writes.
    Flow @ 1 {
        x_in: Read "array<vec4<f32>>",
        v_in: Read "array<vec4<f32>>",
        x_out: ReadWrite "array<vec4<f32>>",
        v_out: ReadWrite "array<vec4<f32>>",
    }
    /// The dispatch's stage slot (time, dt, collider poses): a dynamic offset into one buffer.
    StageSlot @ 2 {
        stage: Dynamic "Stage",
    }
    /// A fused step's end slot, whose collider poses its projection uses.
    StageEnd @ 3 {
        stage_end: Dynamic "Stage",
    }
    /// Every stage slot of the submission, as words (`STAGE_STRIDE_WORDS` apart), for a kernel
    /// that runs many steps: fused_frame reads each step's collider poses there.
    StageWords @ 3 {
        stage_words: Read "array<u32>",
    }
}

impl Group {
    /// Its bindings' WGSL declarations.
    pub fn wgsl(self) -> String {
        self.bindings()
            .iter()
            .enumerate()
            .map(|(i, b)| b.wgsl(self.index(), i))
            .collect()
    }
}
