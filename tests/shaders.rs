//! The shaders, checked without a GPU: every program validates with naga; the structs shared
//! with the host (`src/gpu/layout.rs`) have the WGSL's layout; and the kernel table
//! (`src/gpu/kernels.rs`) matches the WGSL and the CPU backend: every compute entry point is in
//! the table and every row is in the WGSL, in the file the row names; every CPU namesake the
//! table names is a function of that name in `src/cpu/`; every program binds what the bind
//! group table (`src/gpu/bindings.rs`) declares and no WGSL file declares a binding of its own;
//! and every library a program imports finds there the bindings and functions it names.

use std::collections::BTreeSet;

use hooke::gpu::bindings::Slot;
use hooke::gpu::kernels::{Twin, table};

fn parse(name: &str, src: &str) -> naga::Module {
    naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)))
}

#[test]
fn every_shader_validates_with_naga() {
    for (name, src) in hooke::gpu::programs() {
        let module = parse(name, &src);
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
        assert!(
            module
                .entry_points
                .iter()
                .any(|e| e.stage == naga::ShaderStage::Compute),
            "{name}: no compute entry point"
        );
    }
}

#[test]
fn shared_structs_match_their_wgsl_layout() {
    // implicit.wgsl holds the solver's status; every program starts with common.wgsl's structs.
    let programs = hooke::gpu::programs();
    let (name, src) = programs
        .iter()
        .find(|(n, _)| *n == "implicit.wgsl")
        .unwrap_or_else(|| panic!("no implicit.wgsl"));
    let module = parse(name, src);
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .unwrap_or_else(|e| panic!("{e}"));
    for (name, rust_size) in hooke::gpu::layout::SHARED_STRUCTS {
        if name.starts_with("vec4") {
            continue;
        }
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name} in WGSL"));
        let wgsl_size = layouter[handle].size as usize;
        assert_eq!(
            wgsl_size, rust_size,
            "{name}: WGSL size {wgsl_size}, Rust size {rust_size}"
        );
        if let naga::TypeInner::Struct { members, .. } = &ty.inner {
            let offsets: Vec<(String, u32)> = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect();
            let expect: Vec<(&str, usize)> = match name {
                "Params" => vec![
                    (
                        "gravity",
                        std::mem::offset_of!(hooke::gpu::layout::Params, gravity),
                    ),
                    (
                        "ground_max_depth",
                        std::mem::offset_of!(hooke::gpu::layout::Params, ground_max_depth),
                    ),
                ],
                "Collider" => vec![
                    (
                        "shape",
                        std::mem::offset_of!(hooke::gpu::layout::Collider, shape),
                    ),
                    (
                        "max_depth",
                        std::mem::offset_of!(hooke::gpu::layout::Collider, max_depth),
                    ),
                ],
                "Stage" => vec![
                    (
                        "step",
                        std::mem::offset_of!(hooke::gpu::layout::Stage, step),
                    ),
                    (
                        "poses",
                        std::mem::offset_of!(hooke::gpu::layout::Stage, poses),
                    ),
                ],
                "FrameSolve" => vec![
                    (
                        "overran",
                        std::mem::offset_of!(hooke::gpu::layout::FrameSolve, overran),
                    ),
                    (
                        "newton_most",
                        std::mem::offset_of!(hooke::gpu::layout::FrameSolve, newton_most),
                    ),
                    (
                        "cg_most",
                        std::mem::offset_of!(hooke::gpu::layout::FrameSolve, cg_most),
                    ),
                ],
                "Solver" => vec![
                    (
                        "iterations",
                        std::mem::offset_of!(hooke::gpu::layout::SolverStatus, iterations),
                    ),
                    (
                        "cg_active",
                        std::mem::offset_of!(hooke::gpu::layout::SolverStatus, cg_active),
                    ),
                    (
                        "converged",
                        std::mem::offset_of!(hooke::gpu::layout::SolverStatus, converged),
                    ),
                ],
                "SpringLimits" => vec![
                    (
                        "relax",
                        std::mem::offset_of!(hooke::model::SpringLimits, relax),
                    ),
                    (
                        "break_strain",
                        std::mem::offset_of!(hooke::model::SpringLimits, break_strain),
                    ),
                ],
                "Spring" => vec![
                    ("rest", std::mem::offset_of!(hooke::model::Spring, rest_m)),
                    (
                        "damping",
                        std::mem::offset_of!(hooke::model::Spring, damping_n_s_per_m),
                    ),
                ],
                _ => vec![],
            };
            for (member, rust_off) in expect {
                let wgsl_off = offsets
                    .iter()
                    .find(|(n, _)| n == member)
                    .map(|(_, o)| *o as usize);
                assert_eq!(
                    wgsl_off,
                    Some(rust_off),
                    "{name}.{member}: WGSL offset {wgsl_off:?}, Rust {rust_off}"
                );
            }
        }
    }
    // The solver's scratch: the two statuses, the frame record where the host writes and reads
    // it, then the partials.
    let scratch = module
        .types
        .iter()
        .find_map(|(_, t)| match (&t.name, &t.inner) {
            (Some(n), naga::TypeInner::Struct { members, .. }) if n == "Scratch" => Some(members),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no struct Scratch in WGSL"));
    let offset = |member: &str| {
        scratch
            .iter()
            .find(|m| m.name.as_deref() == Some(member))
            .map(|m| u64::from(m.offset))
    };
    use hooke::gpu::layout::FrameSolve;
    assert_eq!(offset("frame"), Some(FrameSolve::OFFSET));
    assert_eq!(
        offset("partials"),
        Some(FrameSolve::OFFSET + FrameSolve::SIZE)
    );
}

#[test]
fn every_wgsl_entry_point_is_in_the_kernel_table_and_every_row_in_the_wgsl() {
    let mut in_wgsl = BTreeSet::new();
    for (file, src) in hooke::gpu::programs() {
        for e in parse(file, &src).entry_points {
            assert_eq!(e.stage, naga::ShaderStage::Compute, "{file}: {}", e.name);
            in_wgsl.insert((file.to_owned(), e.name));
        }
    }
    let in_table: BTreeSet<(String, String)> = table()
        .iter()
        .map(|s| (s.program.file().to_owned(), s.entry.to_owned()))
        .collect();
    assert_eq!(
        table().len(),
        in_table.len(),
        "a kernel is in the table twice"
    );
    let missing: Vec<_> = in_wgsl.difference(&in_table).collect();
    let stale: Vec<_> = in_table.difference(&in_wgsl).collect();
    assert!(
        missing.is_empty() && stale.is_empty(),
        "entry points not in the table: {missing:?}; rows not in the WGSL: {stale:?}"
    );
}

/// The functions `src/cpu/<module>.rs` declares.
fn cpu_functions(module: &str) -> BTreeSet<String> {
    let path = format!("{}/src/cpu/{module}.rs", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    text.split("fn ")
        .skip(1)
        .filter_map(|rest| rest.split(['(', '<']).next())
        .map(str::to_owned)
        .collect()
}

#[test]
fn every_cpu_namesake_exists_and_shares_its_kernels_name() {
    let modules = [
        "collide",
        "collide_masses",
        "forces",
        "grid",
        "implicit",
        "integrate",
        "reduce",
        "springs",
        "xpbd",
    ];
    let all_cpu: BTreeSet<String> = modules.iter().flat_map(|m| cpu_functions(m)).collect();
    for s in table() {
        match s.twin {
            Twin::Cpu(path) => {
                let segments: Vec<&str> = path.split("::").collect();
                assert_eq!(
                    segments.last(),
                    Some(&s.entry),
                    "{}: namesake {path}",
                    s.entry
                );
                assert_eq!(segments[0], "cpu", "{path}");
                assert!(
                    cpu_functions(segments[1]).contains(s.entry),
                    "{}: no fn {} in src/cpu/{}.rs",
                    s.entry,
                    s.entry,
                    segments[1]
                );
            }
            Twin::None(reason) => {
                assert!(!reason.is_empty(), "{}: no reason given", s.entry);
                assert!(
                    !all_cpu.contains(s.entry),
                    "{}: src/cpu has a function of that name; name it as the namesake",
                    s.entry
                );
            }
        }
    }
}

#[test]
fn every_program_binds_what_the_table_declares_and_no_wgsl_file_declares_a_binding() {
    use hooke::gpu::programs::Program;
    for p in Program::ALL {
        let (file, src) = (p.file(), hooke::gpu::programs::Program::text(p));
        assert!(
            !src.contains("@group(") && !src.contains("@binding("),
            "{file} declares a binding: bind groups are declared once, in src/gpu/bindings.rs"
        );
        let module = parse(file, &hooke::gpu::programs()[p as usize].1);
        let mut declared: Vec<(u32, u32, String, Slot)> = module
            .global_variables
            .iter()
            .filter_map(|(_, g)| {
                let b = g.binding.as_ref()?;
                let slot = match g.space {
                    naga::AddressSpace::Uniform => Slot::Uniform,
                    naga::AddressSpace::Storage { access }
                        if access.contains(naga::StorageAccess::STORE) =>
                    {
                        Slot::ReadWrite
                    }
                    _ => Slot::Read,
                };
                Some((b.group, b.binding, g.name.clone()?, slot))
            })
            .collect();
        declared.sort_by_key(|(g, b, _, _)| (*g, *b));
        let mut expected: Vec<(u32, u32, String, Slot)> = hooke::gpu::program_groups(p)
            .into_iter()
            .flat_map(|g| {
                g.bindings()
                    .into_iter()
                    .enumerate()
                    .map(move |(i, b)| (g.index(), i as u32, b.name.to_owned(), b.slot))
            })
            .collect();
        expected.sort_by_key(|(g, b, _, _)| (*g, *b));
        assert_eq!(declared, expected, "{file}");
        // Every kernel's own group 0 is the start of the program's: a kernel binds a prefix.
        let program_group0 = hooke::gpu::program_groups(p)[0].bindings();
        for s in table().iter().filter(|s| s.program == p) {
            let own = s.group.bindings();
            assert_eq!(
                own[..],
                program_group0[..own.len()],
                "{file}: {}'s group {:?}",
                s.entry,
                s.group
            );
        }
    }
}

#[test]
fn every_library_a_program_imports_finds_its_bindings_and_functions_there() {
    use hooke::gpu::programs::Program;
    let missing: Vec<String> = Program::ALL
        .into_iter()
        .flat_map(hooke::gpu::missing)
        .collect();
    assert!(missing.is_empty(), "{}", missing.join("\n"));
    // The check can fail: a program without x_in, spring_end or a library is told so (and one
    // that defines spring_range, collider_pose and solve_dt is not told of them).
    let unmet = hooke::gpu::unmet(
        "test.wgsl",
        ["mass_force", "no_such_library"].into_iter(),
        &[
            "params",
            "offsets",
            "colliders",
            "mass",
            "deriv",
            "v_in",
            "stage",
        ],
        "fn spring_range(i: u32) -> vec2<u32> {}\nfn collider_pose(k: u32) -> Pose {}\nfn solve_dt() -> f32 {}",
    );
    assert_eq!(unmet.len(), 3, "{unmet:?}");
    assert!(unmet[0].contains("binding 'x_in'"), "{unmet:?}");
    assert!(unmet[1].contains("spring_end()"), "{unmet:?}");
    assert!(unmet[2].contains("no_such_library"), "{unmet:?}");
}
