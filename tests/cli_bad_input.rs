//! Bad input to the `hooke` binary ends in one clear error: a scene file's field and position
//! with what is allowed, a collider or spring effect that cannot work, a command-line value out
//! of range, and an integrator the scene cannot use.

use crate::common::{hooke_within_memory, temp_dir, text};

/// Every bad input here runs under a 2 GB address space (`ulimit -v`): one whose refusal needed
/// more would fail its test, not the machine.
fn hooke(args: &[&str]) -> std::process::Output {
    hooke_within_memory(args, 2 << 30)
}

/// Run `check` on scene text; expect failure with one line naming the field and position.
fn expect_scene_error(name: &str, toml: &str, field: &str, position: &str, says: &str) {
    let dir = temp_dir("bad");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, toml).unwrap_or_else(|e| panic!("{e}"));
    let out = hooke(&["check", &path.to_string_lossy()]);
    let err = text(&out.stderr);
    assert!(!out.status.success(), "{name}: accepted bad input");
    assert_eq!(out.status.code(), Some(1), "{name}: {err}");
    assert!(!err.contains("panicked"), "{name}: panicked: {err}");
    assert_eq!(
        err.trim().lines().count(),
        1,
        "{name}: want one line, got:\n{err}"
    );
    let want_pos = format!("{}:{position}", path.display());
    assert!(
        err.contains(&want_pos),
        "{name}: no position {want_pos} in: {err}"
    );
    assert!(
        err.contains(field),
        "{name}: field `{field}` not named in: {err}"
    );
    assert!(err.contains(says), "{name}: `{says}` not in: {err}");
    let _ = std::fs::remove_dir_all(dir);
}

const BODY: &str = "name = \"t\"\n[[bodies]]\nname = \"b\"\ngrid = [4, 4]\nspacing_m = 0.1\n";
/// The same scene with a table before the body, so the table's lines come first.
fn with_table(table: &str) -> String {
    format!(
        "name = \"t\"\n{table}[[bodies]]\nname = \"b\"\ngrid = [4, 4]\nspacing_m = 0.1\nmass_kg = 1.0\n"
    )
}

#[test]
fn bad_colliders_and_spring_effects_give_one_clear_error() {
    expect_scene_error(
        "keyframes-backwards",
        &with_table(
            "[[effects.spheres]]\nradius_m = 0.1\nkeyframes = [{ time_secs = 1.0, center_m = [0, 0, 0] }, { time_secs = 0.5, center_m = [0, 1, 0] }]\n",
        ),
        "effects.spheres[0].keyframes[1].time_secs",
        "4:71",
        "must increase",
    );
    expect_scene_error(
        "keyframes-and-centre",
        &with_table(
            "[[effects.spheres]]\nradius_m = 0.1\ncenter_m = [0, 0, 0]\nkeyframes = [{ time_secs = 1.0, center_m = [0, 0, 0] }]\n",
        ),
        "effects.spheres[0].keyframes",
        "5:13",
        "remove `center_m`",
    );
    expect_scene_error(
        "sphere-without-position",
        &with_table("[[effects.spheres]]\nradius_m = 0.1\n"),
        "effects.spheres[0].center_m",
        "2:1",
        "is missing",
    );
    expect_scene_error(
        "box-negative-size",
        &with_table("[[effects.boxes]]\ncenter_m = [0, 0, 0]\nhalf_extents_m = [0.1, -0.2, 0.1]\n"),
        "effects.boxes[0].half_extents_m[1]",
        "4:24",
        "greater than zero",
    );
    expect_scene_error(
        "plane-zero-normal",
        &with_table("[[effects.planes]]\npoint_m = [0, 0, 0]\nnormal = [0, 0, 0]\n"),
        "effects.planes[0].normal",
        "4:10",
        "non-zero direction",
    );
    expect_scene_error(
        "tears-before-it-yields",
        &format!(
            "{}[bodies.plasticity]\nyield_strain = 0.2\ncreep_per_s = 1.0\n[bodies.tearing]\nmax_strain = 0.1\n",
            with_table("")
        ),
        "bodies[0].tearing.max_strain",
        "11:14",
        "larger than yield_strain",
    );
}

#[test]
fn bad_scene_files_give_one_clear_error_with_field_and_position() {
    expect_scene_error(
        "unknown-key",
        &format!("{BODY}mass_kg = 1.0\nmas_kg = 2.0\n"),
        "mas_kg",
        "7:1",
        "unknown field",
    );
    expect_scene_error(
        "negative-mass",
        &format!("{BODY}mass_kg = -1.0\n"),
        "bodies[0].mass_kg",
        "6:11",
        "greater than zero",
    );
    expect_scene_error(
        "zero-mass",
        &format!("{BODY}mass_kg = 0.0\n"),
        "bodies[0].mass_kg",
        "6:11",
        "greater than zero",
    );
    expect_scene_error(
        "zero-stiffness",
        &format!("{BODY}mass_kg = 1.0\nsprings.structural = {{ stiffness_n_per_m = 0.0 }}\n"),
        "bodies[0].springs.structural.stiffness_n_per_m",
        "7:44",
        "greater than zero",
    );
    expect_scene_error(
        "negative-stiffness",
        &format!("{BODY}mass_kg = 1.0\nsprings.bending = {{ stiffness_n_per_m = -5.0 }}\n"),
        "bodies[0].springs.bending.stiffness_n_per_m",
        "7:41",
        "greater than zero",
    );
    expect_scene_error(
        "dt-zero",
        &with_table("[solver]\ndt_secs = 0.0\n"),
        "solver.dt_secs",
        "3:11",
        "greater than zero",
    );
    expect_scene_error(
        "dt-negative",
        &with_table("[solver]\ndt_secs = -0.001\n"),
        "solver.dt_secs",
        "3:11",
        "greater than zero",
    );
    expect_scene_error(
        "nan",
        &format!("{BODY}mass_kg = nan\n"),
        "bodies[0].mass_kg",
        "6:11",
        "finite",
    );
    expect_scene_error(
        "nan-gravity",
        &with_table("[effects]\ngravity_m_per_s2 = [0.0, nan, 0.0]\n"),
        "effects.gravity_m_per_s2[1]",
        "3:26",
        "finite",
    );
    expect_scene_error(
        "empty-grid",
        "name = \"t\"\n[[bodies]]\nname = \"b\"\ngrid = [4, 0]\nspacing_m = 0.1\nmass_kg = 1.0\n",
        "bodies[0].grid[1]",
        "4:12",
        "empty",
    );
    expect_scene_error(
        "no-grid-axes",
        "name = \"t\"\n[[bodies]]\nname = \"b\"\ngrid = []\nspacing_m = 0.1\nmass_kg = 1.0\n",
        "bodies[0].grid",
        "4:8",
        "1, 2 or 3",
    );
    expect_scene_error(
        "pin-outside",
        &format!("{BODY}mass_kg = 1.0\npins = [[0, 0], [2, 4]]\n"),
        "bodies[0].pins[1][1]",
        "7:21",
        "outside the grid",
    );
    expect_scene_error(
        "pin-wrong-dim",
        &format!("{BODY}mass_kg = 1.0\npins = [[1]]\n"),
        "bodies[0].pins[0]",
        "7:9",
        "2 entries",
    );
    expect_scene_error(
        "wrong-type",
        &format!("{BODY}mass_kg = \"heavy\"\n"),
        "mass_kg",
        "6:11",
        "invalid type",
    );
    expect_scene_error(
        "restitution",
        &with_table("[effects.ground]\nrestitution = 1.5\n"),
        "effects.ground.restitution",
        "3:15",
        "between 0 (the impact ends at rest on the surface) and 1",
    );
    expect_scene_error(
        "huge-grid",
        "name = \"t\"\n[[bodies]]\nname = \"b\"\ngrid = [100000, 100000, 100000]\nspacing_m = 0.1\nmass_kg = 1.0\n",
        "bodies[0].grid",
        "4:8",
        "limit",
    );
    expect_scene_error(
        "self-collision-radius",
        &with_table("[effects.self_collision]\nradius_m = 0.06\nstiffness_n_per_m = 100.0\n"),
        "effects.self_collision.radius_m",
        "3:12",
        "spacing_m = 0.1 m, so its grid neighbours would repel at rest; use radius_m = 0.0450 m",
    );
    expect_scene_error(
        "self-collision-zero-radius",
        &with_table("[effects.self_collision]\nradius_m = 0.0\nstiffness_n_per_m = 100.0\n"),
        "effects.self_collision.radius_m",
        "3:12",
        "greater than zero",
    );
    expect_scene_error(
        "self-collision-restitution",
        &with_table(
            "[effects.self_collision]\nradius_m = 0.01\nstiffness_n_per_m = 100.0\nrestitution = -0.1\n",
        ),
        "effects.self_collision.restitution",
        "5:15",
        "between 0",
    );
    expect_scene_error(
        "self-collision-implicit",
        &with_table(
            "[solver]\nintegrator = \"implicit\"\n[effects.self_collision]\nradius_m = 0.01\nstiffness_n_per_m = 100.0\n",
        ),
        "solver.integrator",
        "3:14",
        "implicit Euler does not support mass–mass contact",
    );
    expect_scene_error("syntax", "name = \"t\"\n[[bodies]\n", "", "2:", "");
}

/// Implicit Euler chosen on the command line for a scene with mass–mass contact: refused, with
/// what to use instead.
#[test]
fn implicit_euler_with_mass_contact_is_refused_clearly() {
    let out = hooke(&[
        "check",
        "pile",
        "--integrator",
        "implicit",
        "--backend",
        "cpu",
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--integrator implicit does not support mass–mass contact")
            && err.contains("semi-implicit, verlet or rk4")
            && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn bad_command_line_values_are_clear_errors() {
    for (args, says) in [
        (
            vec!["check", "hair", "--dt", "0"],
            "--dt must be a positive",
        ),
        (
            vec!["check", "hair", "--dt", "NaN"],
            "--dt must be a positive",
        ),
        (
            vec!["check", "hair", "--duration", "-1"],
            "--duration must be a positive",
        ),
        (
            vec!["check", "nonexistent-scene"],
            "unknown scene 'nonexistent-scene'",
        ),
        // Once a 31-digit decimal and a 29-digit step count, naming nothing.
        (
            vec!["check", "hair", "--dt", "1e-30"],
            "--dt = 1.000e-30 s would need 1.667e28 steps a frame, more than the 4294967295",
        ),
    ] {
        expect_failure(&args, 1, says);
    }
    // `--dt` takes a fraction, as `--compare` does; a broken one says what it takes.
    expect_failure(
        &["check", "hair", "--dt", "1/x"],
        2,
        "expected seconds (like 0.001 or 1/60) or `auto`, got '1/x'",
    );
    let out = hooke(&["check", "hair", "--backend", "cpu", "--dt", "1/600"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("dt = 1.6667e-3 s (10 substeps per frame at 60 Hz)"),
        "{}",
        text(&out.stdout)
    );
}

/// Run `hooke` with `args`; expect exit status `code` (1: our error, 2: the argument parser's)
/// and a message that says `says`, with no panic.
fn expect_failure(args: &[&str], code: i32, says: &str) {
    let out = hooke(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(
        err.contains(says) && !err.contains("panicked"),
        "{args:?}: {err}"
    );
}

/// Misleading or silent cases once: a value past f32's range says so (not "got inf"),
/// `frames` with `duration_secs` is refused like `substeps` with `dt_secs`, options that do
/// nothing in context are refused or noted, `--compare` has a cap that says why, `--steps 0`
/// and an `--out` that is not a folder are errors.
#[test]
fn options_and_values_that_would_do_nothing_or_mislead_are_refused_or_noted() {
    expect_scene_error(
        "stiffness-1e300",
        &format!(
            "{BODY}mass_kg = 1.0\n[bodies.springs]\nstructural = {{ stiffness_n_per_m = 1e300 }}\n"
        ),
        "bodies[0].springs.structural.stiffness_n_per_m",
        "8:",
        "within f32's range",
    );
    expect_scene_error(
        "frames-and-duration",
        &with_table("[solver]\nframes = 10\nduration_secs = 1.0\n"),
        "solver.frames",
        "3:",
        "either `frames` or `duration_secs`, not both",
    );
    // 4e9 sweeps a step could not be stopped in time; 100 000 are allowed.
    expect_scene_error(
        "vbd-sweeps-4e9",
        &with_table("[solver]\nintegrator = \"vbd\"\nvbd_iterations = 4000000000\n"),
        "solver.vbd_iterations",
        "4:",
        "must be at most 100000",
    );
    let dir = temp_dir("refused-options");
    let not_a_folder = dir.join("file");
    std::fs::write(&not_a_folder, "").unwrap_or_else(|e| panic!("{e}"));
    let many = vec!["rk4"; 17].join(",");
    for (args, says) in [
        (
            vec![
                "run",
                "hair",
                "--backend",
                "cpu",
                "--frames",
                "1",
                "--overlay",
            ],
            "--overlay shapes a comparison",
        ),
        (
            vec![
                "run",
                "hair",
                "--backend",
                "cpu",
                "--frames",
                "1",
                "--colour-by",
                "gap",
            ],
            "--colour-by shapes a comparison",
        ),
        (
            vec![
                "run",
                "hair",
                "--backend",
                "cpu",
                "--frames",
                "1",
                "--compare",
                &many,
            ],
            "a comparison holds at most 16",
        ),
        (
            vec![
                "run",
                "hair",
                "--backend",
                "cpu",
                "--integrator",
                "xpbd",
                "--xpbd-iterations",
                "100001",
            ],
            "--xpbd-iterations 100001 is more than 100000 sweeps a step",
        ),
        (
            vec![
                "check",
                "jello",
                "--backend",
                "cpu",
                "--substeps",
                "4000000000",
            ],
            "below what f32 positions resolve: a mass 1.051 m from the origin moves only if it goes faster than 1.5e4 m/s",
        ),
        (
            vec!["bench", "throughput", "hair", "--steps", "0"],
            "--steps",
        ),
        (
            vec![
                "bench",
                "accuracy",
                "hair",
                "--out",
                &not_a_folder.to_string_lossy(),
            ],
            "not a folder",
        ),
    ] {
        // The argument parser refuses a zero step count (status 2); the rest are ours.
        let code = if args.contains(&"--steps") { 2 } else { 1 };
        expect_failure(&args, code, says);
    }
    // Slow masses cannot move at 1.7e-10 s: said, and the run goes on.
    let small = hooke(&[
        "check",
        "jello",
        "--backend",
        "cpu",
        "--substeps",
        "100000000",
    ]);
    assert!(small.status.success(), "{}", text(&small.stderr));
    // `check` prints what it notes with its report, on stdout.
    assert!(
        text(&small.stdout).contains("stays where it is unless it goes faster than 375.92 m/s"),
        "{}",
        text(&small.stdout)
    );
    let noted = hooke(&[
        "check",
        "hair",
        "--backend",
        "cpu",
        "--adapter",
        "x",
        "--vbd-iterations",
        "20",
    ]);
    let err = text(&noted.stderr);
    assert!(noted.status.success(), "{err}");
    assert!(
        err.contains("note: --adapter is for the GPU backend; --backend cpu ignores it"),
        "{err}"
    );
    let out = text(&noted.stdout);
    assert!(
        format!("{out}{err}").contains("--vbd-iterations sets vbd's sweeps"),
        "{out}{err}"
    );
    let _ = std::fs::remove_dir_all(dir);
}
