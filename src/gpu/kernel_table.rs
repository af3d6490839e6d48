//! The kernel table's rows, one per WGSL entry point: what `kernels.rs` makes the `Kernel` enum
//! and its specs from, and what `conformance/twins.rs` checks the CPU namesakes of.

/// The table's rows, handed to `$callback` (`kernels!` in `kernels.rs`; `conformance/twins.rs`,
/// above both backends, checks that every named CPU namesake exists, so that this backend
/// imports nothing from the other).
macro_rules! kernel_table {
    ($callback:ident) => {
        $callback! {
            // ---- forces.wgsl ----
            /// The full force on every mass (springs, gravity, drag, contact), as accelerations and the
            /// ledger's rates.
            ComputeForces = compute_forces in Forces {
                group: ForcesModel + state, threads: Masses, needs: Always, cpu: (forces),
                // x, v in; offsets; neighbours and springs; acceleration and rates out.
                bytes: |z| z.n * (16 + 16 + 4 + 8 + 32) + z.ns * (2 * 8 + 20) + z.colliders,
            }

            // ---- integrate.wgsl: x, v read and written; derivatives read; ledger read and written ----
            EulerUpdate = euler_update in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (4 * 16 + 32 + 2 * 16 + 8),
            }
            SemiImplicitUpdate = semi_implicit_update in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (4 * 16 + 32 + 2 * 16 + 8),
            }
            Rk2Stage = rk2_stage in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (2 * 16 + 32 + 2 * 16 + 8),
            }
            Rk2Final = rk2_final in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (5 * 16 + 32 + 2 * 16 + 8),
            }
            Rk4Begin = rk4_begin in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (2 * 16 + 32 + 2 * 16 + 3 * 16 + 8),
            }
            Rk4Mid = rk4_mid in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (3 * 16 + 32 + 2 * 16 + 2 * 3 * 16 + 8),
            }
            Rk4Final = rk4_final in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (5 * 16 + 32 + 3 * 16 + 2 * 16 + 8),
            }
            VerletDrift = verlet_drift in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (3 * 16 + 32 + 16 + 2 * 16 + 8),
            }
            VerletKick = verlet_kick in Integrate {
                group: Integrate, threads: Masses, needs: Always, cpu: (integrate),
                bytes: |z| z.n * (2 * 16 + 32 + 2 * 16 + 2 * 16 + 8),
            }
            // ---- implicit.wgsl: implicit Euler, a whole step in one workgroup (small systems) ----
            ImplicitStep = implicit_step in Implicit {
                group: Solve, threads: OneGroup, needs: ImplicitInGroup, cpu: (implicit),
            }

            XpbdPredict = xpbd_predict in Integrate {
                group: Integrate, threads: Masses, needs: Xpbd, cpu: (integrate),
                // v and deriv read; v, dx (xt) and ledger written.
                bytes: |z| z.n * (16 + 32 + 2 * 16 + 2 * 16),
            }
            XpbdUpdateVelocity = xpbd_update_velocity in Integrate {
                group: Integrate, threads: Masses, needs: Xpbd, cpu: (xpbd),
                // dx (xt) read; x read and written; v written.
                bytes: |z| z.n * (4 * 16),
            }

            VbdPredict = vbd_predict in Integrate {
                group: Integrate, threads: Masses, needs: Vbd, cpu: (vbd),
                // x, v and the last step's v (sums) read; the iterate (xt, vt) written.
                bytes: |z| z.n * (5 * 16),
            }
            VbdFinal = vbd_final in Integrate {
                group: Integrate, threads: Masses, needs: Vbd, cpu: (vbd),
                // The iterate, rates and masses read; x, v, sums written; ledger read and
                // written; a workgroup's residual sums written.
                bytes: |z| z.n * (2 * 16 + 16 + 8 + 3 * 16 + 2 * 16 + 16) + z.n.div_ceil(64) * 16,
            }
            VbdResidual = vbd_residual in Integrate {
                group: Integrate, threads: OneGroup, needs: Vbd, cpu: (vbd),
                // vbd_final's workgroup sums read.
                bytes: |z| z.n.div_ceil(64) * 16,
            }

            // ---- vbd.wgsl: VBD's masses, solved colour by colour ----
            /// Dispatched once per colour and sweep; its bytes are per sweep over all colours.
            VbdSolveMass = vbd_solve_mass in Vbd {
                group: VbdSolve, threads: Colour, needs: Vbd, cpu: (vbd),
                // Index, mass, offsets; the iterate read and written, the start read; each CSR
                // entry's spring and the other end's iterate.
                bytes: |z| z.n * (4 + 8 + 4 + 4 * 16 + 2 * 16) + z.ns * 2 * (8 + 20 + 2 * 16) + z.colliders,
            }

            /// Every sweep over every colour in one workgroup, for small scenes.
            VbdSweeps = vbd_sweeps in VbdSweeps {
                group: VbdSweeps, threads: OneGroup, needs: Vbd,
                cpu: "every sweep of vbd_solve_mass over every colour in one workgroup; the CPU's sweeps are in vbd.rs",
                // As vbd_solve_mass over all the masses, once per sweep.
                bytes: |z| z.n * (4 + 8 + 4 + 4 * 16 + 2 * 16) + z.ns * 2 * (8 + 20 + 2 * 16) + z.colliders,
            }

            // ---- xpbd.wgsl: XPBD's springs, projected colour by colour ----
            /// Dispatched once per colour and sweep; its bytes are per sweep over all colours.
            XpbdSolveSpring = xpbd_solve_spring in Xpbd {
                group: XpbdSolve, threads: Colour, needs: Xpbd, cpu: (xpbd),
                // Spring, constants, index and multiplier; both ends' mass, x and dx read, dx written.
                bytes: |z| z.ns * (20 + 8 + 4 + 2 * 4 + 2 * (8 + 16 + 2 * 16)),
            }
            /// Every sweep over every colour in one workgroup, for small scenes.
            XpbdSweeps = xpbd_sweeps in XpbdSweeps {
                group: XpbdSweeps, threads: OneGroup, needs: Xpbd,
                cpu: "every sweep of xpbd_solve_spring over every colour in one workgroup; the CPU's sweeps are in xpbd.rs",
                // As xpbd_solve_spring over all the springs, once per sweep.
                bytes: |z| z.ns * (20 + 8 + 4 + 2 * 4 + 2 * (8 + 16 + 2 * 16)),
            }

            // ---- implicit.wgsl: the same step a dispatch per pass (larger systems), on the solver's
            // grid of workgroups, two dispatches per CG iteration ----
            RestartCheck = restart_check in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitRestarts,
                cpu: "History::blend_presses_any (cpu/backward.rs), at implicit_step's start",
            }
            ImplicitBegin = implicit_begin in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses, cpu: (implicit),
            }
            ImplicitIterate = implicit_iterate in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses, cpu: (implicit),
            }
            ImplicitFinal = implicit_final in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses, cpu: (implicit),
            }
            SolverBegin = solver_begin in Implicit {
                group: Solve, threads: OneGroup, needs: ImplicitPasses,
                cpu: "resets the solver's status, which the CPU keeps in locals of its solve",
            }
            ForcesAndRhs = forces_and_rhs in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses,
                cpu: "compute_forces and implicit_rhs in one pass; the CPU runs them in turn",
            }
            CgBegin = cg_begin in Implicit {
                group: Solve, threads: OneGroup, needs: ImplicitPasses,
                cpu: "sums the per-workgroup partials of forces_and_rhs; the CPU takes the dot products whole",
            }
            CgApply = cg_apply in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses,
                cpu: "β from the last pass's partials, then apply_system on the next direction z + βp, \
                      taken on the fly; the CPU runs cg_direction and apply_system in turn",
            }
            CgAdvance = cg_advance in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses,
                cpu: "α from cg_apply's partials, then cg_direction and cg_update in one pass; the CPU \
                      runs them in turn",
            }
            NewtonUpdate = newton_update in Implicit {
                group: Solve, threads: SolverGrid, needs: ImplicitPasses, cpu: (implicit),
            }
            NewtonEnd = newton_end in Implicit {
                group: Solve, threads: OneGroup, needs: ImplicitPasses,
                cpu: "reduces newton_update's per-workgroup maxima; the CPU's newton_update takes them whole",
            }

            // ---- multigrid.wgsl: the CG's multigrid cycle on the per-pass path (large systems),
            // a dispatch per level and pass; the level's window names the level ----
            MgLinearise = mg_linearise in Multigrid {
                group: Multigrid, threads: Level, needs: ImplicitMultigrid,
                cpu: "a level's blocks from the finer level's: the CPU's Multigrid::linearise (cpu/aggregates.rs's Level::linearise)",
            }
            MgInvert = mg_invert in Multigrid {
                group: Multigrid, threads: Level, needs: ImplicitMultigrid,
                cpu: "a level's inverted diagonal blocks, the last pass of the CPU's Level::linearise",
            }
            MgFactor = mg_factor in Multigrid {
                group: Multigrid, threads: OneGroup, needs: ImplicitMultigrid,
                cpu: "the coarsest level's dense inverse in f32; the CPU factors it by Cholesky in f64 (Multigrid::factor_coarsest)",
            }
            MgFineDown = mg_fine_down in Multigrid {
                group: Multigrid, threads: SolverGrid, needs: ImplicitMultigrid,
                cpu: "the masses' sweep from zero and the residual after it, the start of the CPU's Multigrid::cycle (smooth_from_zero, apply, residual)",
            }
            MgRestrict = mg_restrict in Multigrid {
                group: Multigrid, threads: Level, needs: ImplicitMultigrid,
                cpu: "the finer level's residual after its sweep, summed into a level's b, and the level's sweep: the CPU's hand_down and coarse_cycle in turn",
            }
            MgSolveCoarsest = mg_solve_coarsest in Multigrid {
                group: Multigrid, threads: OneGroup, needs: ImplicitMultigrid,
                cpu: "the coarsest level's solve, the CPU's Multigrid::solve_coarsest by its factor",
            }
            MgProlong = mg_prolong in Multigrid {
                group: Multigrid, threads: Level, needs: ImplicitMultigrid,
                cpu: "the coarser correction and a sweep, the end of the CPU's coarse_cycle",
            }
            MgFineUp = mg_fine_up in Multigrid {
                group: Multigrid, threads: SolverGrid, needs: ImplicitMultigrid,
                cpu: "the first level's correction and the last sweep on the masses, the end of the CPU's Multigrid::cycle, with cg_advance's partials",
            }
            // The whole step in one workgroup (small systems), the cycle's passes as loops over
            // a level's nodes with barriers between them.
            MgImplicitStep = mg_implicit_step in Multigrid {
                group: Multigrid, threads: OneGroup, needs: ImplicitInGroupMultigrid,
                cpu: "implicit_step's body (implicit_group.wgsl) with the V-cycle making the CG's z: the CPU's implicit_step with its Multigrid",
            }

            // ---- fused.wgsl: the explicit steps with every per-mass pass fused into the force gather ----
            /// Euler or semi-implicit Euler, the whole step.
            FusedStep = fused_step in Fused {
                group: Fused + flow, threads: Masses, needs: Fused, cpu: (fused::FusedStep),
                // x, v in and out; mass; ledger read and written; offsets and links (8 B an end)
                // where no stencil stands for them.
                bytes: |z| z.n * (4 * 16 + 8 + 2 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }
            /// Every Euler or semi-implicit step of a submission in one workgroup, for small
            /// scenes; its bytes are per step.
            FusedFrame = fused_frame in FusedFrame {
                group: FusedFrame + slots, threads: OneGroup, needs: FusedInGroup,
                cpu: "fused_step over and over, in one workgroup; the CPU steps a submission in turn",
                // As fused_step, and B copied back to A.
                bytes: |z| z.n * (4 * 16 + 8 + 2 * 16 + 4 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }
            FusedVerletDrift = fused_verlet_drift in Fused {
                group: Fused + flow, threads: Masses, needs: Fused,
                cpu: "verlet_drift writing the drifted state beside the step's start, for the kick to read",
                // x, v in and out; a(x_n) and rates in; half kick and rates out.
                bytes: |z| z.n * (4 * 16 + 32 + 2 * 16),
            }
            FusedVerletKick = fused_verlet_kick in Fused {
                group: Fused + flow, threads: Masses, needs: Fused,
                cpu: "compute_forces, verlet_kick and project_contacts in one pass; the CPU runs them in turn",
                // x, v in and out; offsets; mass; a and rates out; half kick and rates in; ledger; links.
                bytes: |z| z.n * (4 * 16 + 8 + 32 + 2 * 16 + 2 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }
            FusedRk4Begin = fused_rk4_begin in Fused {
                group: Fused + flow, threads: Masses, needs: Fused,
                cpu: "compute_forces and rk4_begin in one pass; the CPU runs them in turn",
                // x, v in; stage point out; offsets; mass; three sums out; links.
                bytes: |z| z.n * (4 * 16 + 8 + 3 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }
            FusedRk4Mid = fused_rk4_mid in Fused {
                group: FusedMid + flow, threads: Masses, needs: Fused,
                cpu: "compute_forces and rk4_mid in one pass; the CPU runs them in turn",
                // Stage state in; the step's start in; next stage point out; offsets; mass; three sums
                // read and written; links.
                bytes: |z| z.n * (6 * 16 + 8 + 2 * 3 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }
            FusedRk4Final = fused_rk4_final in Fused {
                group: Fused + flow, threads: Masses, needs: Fused,
                cpu: "compute_forces, rk4_final and project_contacts in one pass; the CPU runs them in turn",
                // Stage state in; x, v read and written; offsets; mass; three sums in; ledger; links.
                bytes: |z| z.n * (6 * 16 + 8 + 3 * 16 + 2 * 16) + z.linked_masses * 4 + z.linked_entries * 8 + z.colliders,
            }

            // ---- collide.wgsl ----
            /// The post-step safeguard against tunnelling.
            ProjectContacts = project_contacts in Collide {
                group: Collide, threads: Masses, needs: Always, cpu: (collide),
                bytes: |z| z.n * (4 * 16 + 8) + z.colliders,
            }

            // ---- reduce.wgsl: what a snapshot logs ----
            ComputeStrain = compute_strain in Reduce {
                group: Reduce, threads: Springs, needs: Always, cpu: (reduce),
            }
            ComputeEnergies = compute_energies in Reduce {
                group: Reduce, threads: Energies, needs: Always, cpu: (reduce),
            }

            // ---- springs.wgsl: plasticity and tearing ----
            UpdateSprings = update_springs in Springs {
                group: Springs, threads: Springs, needs: SpringsChange, cpu: (springs),
                // Spring and limits read; two ends; rest length and released energy written.
                bytes: |z| z.ns * (20 + 16 + 2 * 16 + 4 + 2 * 4),
            }
            SumSpringWork = sum_spring_work in Springs {
                group: Springs, threads: Energies, needs: SpringsChange,
                cpu: "per-workgroup sums of the energy update_springs let go, which the CPU's sums whole",
            }

            // ---- grid.wgsl: mass–mass contact's neighbour lists and their hash grid, a
            // counting sort by bucket. The build passes run only when the check finds the lists
            // stale; their traffic is that of a build. ----
            NeighboursCheck = neighbours_check in Grid {
                group: Grid + state, threads: Masses, needs: MassContact,
                cpu: (neighbours::Neighbours),
                // x and the position at the build in.
                bytes: |z| z.n * (16 + 12),
            }
            GridCount = grid_count in Grid {
                group: Grid + state, threads: Masses, needs: MassContact, cpu: (grid::MassGrid),
                // x in; position at the build, bucket out; one atomic count per mass.
                bytes: |z| z.n * (16 + 12 + 4 + 4),
            }
            GridScanBlocks = grid_scan_blocks in Grid {
                group: Grid, threads: ScanBlocks, needs: MassContact,
                cpu: "the GPU's prefix sum over the table, in three passes; one loop in MassGrid's build",
                // Counts in, starts out; block sums.
                bytes: |z| z.table * 8 + z.blocks * 4,
            }
            GridScanSums = grid_scan_sums in Grid {
                group: Grid, threads: OneGroup, needs: MassContact,
                cpu: "the GPU's prefix sum over the table, in three passes; one loop in MassGrid's build",
                bytes: |z| z.blocks * 8 + 4,
            }
            GridScanAdd = grid_scan_add in Grid {
                group: Grid, threads: Buckets, needs: MassContact,
                cpu: "the GPU's prefix sum over the table, in three passes; one loop in MassGrid's build",
                bytes: |z| z.table * 8 + z.blocks * 4,
            }
            GridScatter = grid_scatter in Grid {
                group: Grid, threads: Masses, needs: MassContact, cpu: (grid::MassGrid),
                // Bucket, count and start per mass; the sorted index out.
                bytes: |z| z.n * 16,
            }
            GridSortCells = grid_sort_cells in Grid {
                group: Grid, threads: Buckets, needs: MassContact,
                cpu: "restores the mass order the GPU's atomic scatter loses; the CPU scatters in order",
                // Starts; each bucket's masses read and written.
                bytes: |z| z.table * 8 + z.n * 8,
            }

            /// The build above in one workgroup, for small scenes (`plan::ListBuild`).
            NeighboursBuild = neighbours_build in Grid {
                group: Grid + state, threads: OneGroup, needs: MassContact,
                cpu: "grid_count to neighbour_lists in one workgroup; the CPU builds in Neighbours::neighbour_lists",
                // As grid_count to neighbour_lists together.
                bytes: |z| z.n * (16 + 12 + 4 + 4 + 16 + 16 + 4 + 4 * 16) + z.table * 16,
            }
            NeighbourLists = neighbour_lists in Grid {
                group: Grid + state, threads: Masses, needs: MassContact,
                cpu: (neighbours::Neighbours),
                // x per mass and per candidate (cached); starts; the list out.
                bytes: |z| z.n * (16 + 4 + 4 * 16) + z.table * 4,
            }

            // ---- collide_masses.wgsl ----
            CollideMasses = collide_masses in CollideMasses {
                group: CollideMasses + state, threads: Masses, needs: MassContact, cpu: (collide_masses),
                // x, v, mass, body per mass and per candidate (cached); the list; deriv in and
                // out.
                bytes: |z| z.n * (16 + 16 + 8 + 4 + 4 + 4 * 16 + 2 * 32),
            }
            /// At snapshot time only.
            MassContactEnergy = mass_contact_energy in CollideMasses {
                group: CollideMasses + state, threads: Masses, needs: MassContact,
                cpu: (collide_masses),
                bytes: |z| z.n * (16 + 8 + 4 + 4 + 4 * 16),
            }
        }
    };
}
pub(crate) use kernel_table;
