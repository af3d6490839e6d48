//! The kernel table (`src/gpu/kernels.rs`) against the WGSL and the CPU backend: every compute
//! entry point is in the table and every row is in the WGSL, in the file the row names; every
//! CPU namesake the table names is a function of that name in `src/cpu/`; and each WGSL file's
//! bind group 0 has the bindings the table's group declares. Needs no GPU.

use std::collections::BTreeSet;

use hooke::gpu::kernels::{Slot, Twin, table};

fn parse(name: &str, src: &str) -> naga::Module {
    naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)))
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
fn each_wgsl_files_bind_group_0_is_its_kernels_group() {
    for (file, src) in hooke::gpu::programs() {
        let module = parse(file, &src);
        let mut declared: Vec<(u32, Slot)> = module
            .global_variables
            .iter()
            .filter_map(|(_, g)| {
                let b = g.binding.as_ref().filter(|b| b.group == 0)?;
                let slot = match g.space {
                    naga::AddressSpace::Uniform => Slot::Uniform,
                    naga::AddressSpace::Storage { access }
                        if access.contains(naga::StorageAccess::STORE) =>
                    {
                        Slot::ReadWrite
                    }
                    _ => Slot::Read,
                };
                Some((b.binding, slot))
            })
            .collect();
        declared.sort_by_key(|(b, _)| *b);
        let groups: BTreeSet<String> = table()
            .iter()
            .filter(|s| s.program.file() == file)
            .map(|s| format!("{:?}", s.group))
            .collect();
        assert_eq!(
            groups.len(),
            1,
            "{file}: kernels in several groups {groups:?}"
        );
        let spec = table()
            .iter()
            .find(|s| s.program.file() == file)
            .unwrap_or_else(|| panic!("{file}: no kernel"));
        let expected: Vec<(u32, Slot)> = spec
            .group
            .slots()
            .iter()
            .enumerate()
            .map(|(i, s)| (i as u32, *s))
            .collect();
        assert_eq!(
            declared, expected,
            "{file}: group 0 against {:?}",
            spec.group
        );
    }
}
