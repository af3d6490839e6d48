//! The `hooke` binary end to end: scene listing, `check`, a recording read back with Rerun's own
//! decoder, and bad input that must end in one clear error.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use rerun::log::{Chunk, LogMsg};

fn hooke(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args(args)
        // Never spawn a real viewer from a test.
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|e| panic!("cannot run hooke: {e}"))
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-test-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
    d
}

#[test]
fn scenes_lists_every_built_in_with_a_description() {
    let out = hooke(&["scenes"]);
    assert!(out.status.success());
    let s = text(&out.stdout);
    for name in ["hair", "cloth", "jello", "jello-sphere"] {
        let line = s
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name));
        let line = line.unwrap_or_else(|| panic!("`{name}` missing from:\n{s}"));
        assert!(
            line.len() > name.len() + 10,
            "no description for {name}: {line}"
        );
    }
}

#[test]
fn built_in_names_and_their_files_are_the_same_scene() {
    for b in hooke::scene::BUILT_IN {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/scenes/{}.toml", b.name));
        let from_file =
            hooke::scene::load(&path.to_string_lossy()).unwrap_or_else(|e| panic!("{e}"));
        let by_name = hooke::scene::load(b.name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(from_file.scene, by_name.scene);
    }
}

#[test]
fn check_prints_the_model_and_stable_steps() {
    let out = hooke(&["check", "jello"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let s = text(&out.stdout);
    // 10³ masses; structural 3·10·10·9, shear 6·9·9·10 + 4·9³, bending 3·10·10·8.
    assert!(s.contains("masses: 1000 (0 pinned), springs: 12876"), "{s}");
    assert!(
        s.contains("structural 2700")
            && s.contains("shear      7776")
            && s.contains("bending    2400"),
        "{s}"
    );
    for i in ["euler", "semi-implicit", "rk2", "rk4", "verlet"] {
        assert!(
            s.lines().any(|l| l.trim_start().starts_with(i)),
            "no stable dt for {i}:\n{s}"
        );
    }
    // Far above the limit: a warning that says what to do.
    let out = hooke(&["check", "jello", "--substeps", "2"]);
    let s = text(&out.stdout);
    assert!(
        s.contains("warning: dt = ") && s.contains("substeps per frame"),
        "{s}"
    );
}

/// Decode an .rrd with Rerun's own decoder: per entity, the set of `frame` values and whether it
/// has `sim_time`.
fn read_rrd(path: &Path) -> BTreeMap<String, (BTreeSet<i64>, BTreeSet<i64>)> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut entities: BTreeMap<String, (BTreeSet<i64>, BTreeSet<i64>)> = BTreeMap::new();
    for msg in re_log_encoding::DecoderApp::decode_lazy(std::io::BufReader::new(file)) {
        let msg = msg.unwrap_or_else(|e| panic!("decoding {}: {e}", path.display()));
        let LogMsg::ArrowMsg(_, arrow) = msg else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap_or_else(|e| panic!("{e}"));
        let entry = entities.entry(chunk.entity_path().to_string()).or_default();
        for (name, col) in chunk.timelines() {
            let set = match name.as_str() {
                "frame" => &mut entry.0,
                "sim_time" => &mut entry.1,
                _ => continue, // log_time, added by the SDK
            };
            set.extend(col.times_raw().iter().copied());
        }
    }
    entities
}

#[test]
fn a_recording_without_its_footer_still_holds_every_frame() {
    // --no-rrd-footer: for long runs, Rerun's file sink keeps no chunk index in memory.
    let dir = temp_dir("nofooter");
    let path = dir.join("hair.rrd");
    let out = hooke(&[
        "run",
        "hair",
        "--backend",
        "cpu",
        "--frames",
        "30",
        "--save",
        &path.to_string_lossy(),
        "--no-rrd-footer",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let frames = &read_rrd(&path)["/world/strand_0/masses"].0;
    assert_eq!(frames, &(0..=30).collect::<BTreeSet<i64>>());
    // The same run with its footer is larger by the index.
    let indexed = dir.join("indexed.rrd");
    let out = hooke(&[
        "run",
        "hair",
        "--backend",
        "cpu",
        "--frames",
        "30",
        "--save",
        &indexed.to_string_lossy(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let size = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
    assert!(
        size(&path) < size(&indexed),
        "no footer: {} bytes, with footer: {} bytes",
        size(&path),
        size(&indexed)
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn recordings_show_the_tear_and_every_collider() {
    let dir = temp_dir("effects");
    let frames = 70i64;
    for scene in ["tear", "ramp"] {
        let path = dir.join(format!("{scene}.rrd"));
        let out = hooke(&[
            "run",
            scene,
            "--backend",
            "cpu",
            "--frames",
            &frames.to_string(),
            "--save",
            &path.to_string_lossy(),
        ]);
        assert!(out.status.success(), "{scene}: {}", text(&out.stderr));
        let e = read_rrd(&path);
        let every: BTreeSet<i64> = (0..=frames).collect();
        let on_timeline: &[&str] = if scene == "tear" {
            &[
                "/stats/broken_springs",
                "/energy/dissipated_plastic",
                "/world/colliders/sphere_0",
                "/world/cloth/springs",
            ]
        } else {
            &["/world/colliders/sphere_0"]
        };
        for entity in on_timeline {
            let got = &e
                .get(*entity)
                .unwrap_or_else(|| panic!("{scene}: no {entity}"))
                .0;
            assert_eq!(got, &every, "{scene}: {entity} frames");
        }
        // Fixed colliders are logged once, static.
        if scene == "ramp" {
            for entity in ["/world/colliders/box_0", "/world/colliders/plane_0"] {
                let got = e.get(entity).unwrap_or_else(|| panic!("no {entity}"));
                assert!(got.0.is_empty(), "{entity} is fixed: {got:?}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_saved_recording_has_every_frame_on_both_timelines() {
    let dir = temp_dir("rec");
    let path = dir.join("jello-sphere.rrd");
    let frames = 12u64;
    let out = hooke(&[
        "run",
        "jello-sphere",
        "--frames",
        &frames.to_string(),
        "--save",
        &path.to_string_lossy(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let e = read_rrd(&path);
    let want_frames: BTreeSet<i64> = (0..=frames as i64).collect();
    for entity in [
        "/world/jello/surface",
        "/world/jello/springs",
        "/world/colliders/sphere_0",
        "/energy/kinetic",
        "/energy/total",
        "/energy/dissipated",
        "/energy/dissipated_damping",
        "/energy/dissipated_contact",
        "/stats/max_strain",
    ] {
        let (f, t) = e
            .get(entity)
            .unwrap_or_else(|| panic!("{entity} missing; have {:?}", e.keys()));
        assert_eq!(f, &want_frames, "{entity}: frames");
        assert_eq!(t.len(), want_frames.len(), "{entity}: sim_time values");
        // 40 substeps of 1/2400 s per frame: frame 12 is at 0.2 s = 2e8 ns.
        let last = *t.iter().max().unwrap_or(&0);
        assert!(
            (last - 200_000_000).abs() < 1_000,
            "{entity}: last sim_time {last} ns"
        );
    }
    for static_entity in ["/world/ground", "/scene", "/legend", "/world"] {
        assert!(e.contains_key(static_entity), "{static_entity} missing");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn with_no_viewer_the_run_records_to_a_file_and_says_so() {
    let dir = temp_dir("fallback");
    let out = Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args(["run", "hair", "--backend", "cpu", "--frames", "3"])
        .current_dir(&dir)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("recording to hair.rrd instead") && err.contains("rerun hair.rrd"),
        "{err}"
    );
    let frames = &read_rrd(&dir.join("hair.rrd"))["/world/strand_0/masses"].0;
    assert_eq!(frames.len(), 4);
    let _ = std::fs::remove_dir_all(dir);
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
    let _ = std::fs::remove_file(path);
}

const BODY: &str = "name = \"t\"\n[[bodies]]\nname = \"b\"\ngrid = [4, 4]\nspacing_m = 0.1\n";
/// The same scene with a table before the body, so the table's lines come first.
fn with_table(table: &str) -> String {
    format!(
        "name = \"t\"\n{table}[[bodies]]\nname = \"b\"\ngrid = [4, 4]\nspacing_m = 0.1\nmass_kg = 1.0\n"
    )
}

/// Each built-in scene's GPU step, as `hooke check` prints it: exactly the passes and compiled-in
/// effects its scene file asks for. A new built-in scene must be added here.
const SCENE_PASSES: &[(&str, &str, &str)] = &[
    (
        "hair",
        "compute_forces → semi_implicit_update",
        "HAS_GRAVITY, HAS_DRAG, HAS_DAMPING",
    ),
    (
        "cloth",
        "compute_forces → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_SPHERES, HAS_COLLIDERS, HAS_DAMPING",
    ),
    (
        "jello",
        "compute_forces → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_GROUND, HAS_DAMPING",
    ),
    (
        "jello-sphere",
        "compute_forces → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_GROUND, HAS_SPHERES, HAS_COLLIDERS, HAS_DAMPING",
    ),
    (
        "tear",
        "compute_forces → semi_implicit_update → project_contacts → update_springs",
        "HAS_GRAVITY, HAS_DRAG, HAS_SPHERES, HAS_COLLIDERS, HAS_DAMPING, HAS_TEARING",
    ),
    (
        "ramp",
        "compute_forces → semi_implicit_update → project_contacts → update_springs",
        "HAS_GRAVITY, HAS_GROUND, HAS_SPHERES, HAS_BOXES, HAS_PLANES, HAS_COLLIDERS, HAS_DAMPING, HAS_PLASTICITY",
    ),
    (
        "cloth-fold",
        "grid_count → grid_scan_blocks → grid_scan_sums → grid_scan_add → grid_scatter → grid_sort_cells → compute_forces → collide_masses → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_DAMPING",
    ),
    (
        "pile",
        "grid_count → grid_scan_blocks → grid_scan_sums → grid_scan_add → grid_scatter → grid_sort_cells → compute_forces → collide_masses → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_GROUND, HAS_DAMPING",
    ),
    (
        "cloth-64",
        "compute_forces → semi_implicit_update",
        "HAS_GRAVITY, HAS_DAMPING",
    ),
    (
        "cloth-256",
        "compute_forces → semi_implicit_update",
        "HAS_GRAVITY, HAS_DAMPING",
    ),
    (
        "cloth-1024",
        "compute_forces → semi_implicit_update",
        "HAS_GRAVITY, HAS_DAMPING",
    ),
];

#[test]
fn check_lists_exactly_the_passes_each_built_in_scene_needs() {
    let listed: Vec<&str> = SCENE_PASSES.iter().map(|s| s.0).collect();
    for b in hooke::scene::BUILT_IN {
        assert!(
            listed.contains(&b.name),
            "built-in scene '{}' has no expected pass list here",
            b.name
        );
    }
    for (scene, passes, effects) in SCENE_PASSES {
        let out = hooke(&["check", scene, "--backend", "cpu"]);
        let report = text(&out.stdout);
        assert!(out.status.success(), "{scene}: {}", text(&out.stderr));
        let line = |prefix: &str| {
            report
                .lines()
                .find_map(|l| l.trim().strip_prefix(prefix))
                .unwrap_or_else(|| panic!("{scene}: no `{prefix}` in:\n{report}"))
                .to_owned()
        };
        assert_eq!(line("GPU step passes: "), *passes, "{scene}");
        assert_eq!(line("compiled-in effects: "), *effects, "{scene}");
    }
    // Mass–mass contact is listed among the effects, with its rule and its pair damping.
    let s = text(&hooke(&["check", "pile", "--backend", "cpu"]).stdout);
    assert!(
        s.contains("self-collision (between bodies only): radius 0.02 m, stiffness 1000 N/m per pair, friction 0.5"),
        "pile:\n{s}"
    );
    let s = text(&hooke(&["check", "cloth-fold", "--backend", "cpu"]).stdout);
    assert!(
        s.contains("self-collision (within and between bodies): radius 0.018 m"),
        "cloth-fold:\n{s}"
    );
    // A scene's integrator changes the force and update passes, not the effects' passes.
    let out = hooke(&["check", "tear", "--integrator", "rk2", "--backend", "cpu"]);
    assert!(text(&out.stdout).contains(
        "GPU step passes: compute_forces → rk2_stage → compute_forces → rk2_final → project_contacts → update_springs\n"
    ));
    // Implicit Euler: Newton iterations, each a conjugate-gradient solve, then the update.
    let out = hooke(&[
        "check",
        "hair",
        "--integrator",
        "implicit",
        "--backend",
        "cpu",
    ]);
    let s = text(&out.stdout);
    assert!(
        s.contains(
            "GPU step passes: implicit_begin → solver_begin → [Newton: implicit_iterate → compute_forces → implicit_rhs → cg_begin → [CG: apply_system → cg_alpha → cg_update → cg_beta → cg_direction] → newton_update → newton_end] → implicit_final\n"
        ),
        "hair, implicit:\n{s}"
    );
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
        "between 0.05 and 1",
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
    ] {
        let out = hooke(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(says) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn the_readme_scene_example_is_a_valid_scene() {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .unwrap_or_else(|e| panic!("{e}"));
    let start = readme
        .find("```toml\n")
        .unwrap_or_else(|| panic!("no toml block in README"))
        + 8;
    let len = readme[start..]
        .find("```")
        .unwrap_or_else(|| panic!("unterminated toml block"));
    let scene =
        hooke::scene::from_toml(&readme[start..start + len], hooke::error::SceneOrigin::Text)
            .unwrap_or_else(|e| panic!("{e}"));
    let model = hooke::model::build(&scene);
    assert_eq!(model.mass_count(), 1000);
    assert_eq!(model.pinned_count(), 1);
}

#[test]
fn without_any_gpu_adapter_the_run_fails_clearly_before_writing_anything() {
    let dir = temp_dir("noadapter");
    let path = dir.join("x.rrd");
    // No Metal on Linux (nor anywhere here): wgpu finds no adapter at all.
    let out = Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args([
            "run",
            "hair",
            "--frames",
            "2",
            "--save",
            &path.to_string_lossy(),
        ])
        .env("WGPU_BACKEND", "metal")
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no GPU adapter found")
            && err.contains("--backend cpu")
            && err.contains("mesa-vulkan-drivers"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        !path.exists(),
        "a recording was started before the backend failed"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_diverging_run_says_where_and_keeps_its_good_frames() {
    let dir = temp_dir("diverge");
    let path = dir.join("hair.rrd");
    // Forward Euler at the hair scene's dt is 19 times past its stable step.
    let out = hooke(&[
        "run",
        "hair",
        "--backend",
        "cpu",
        "--integrator",
        "euler",
        "--save",
        &path.to_string_lossy(),
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("warning: dt = "),
        "check's warning should come first: {err}"
    );
    for needle in [
        "diverged at step",
        "at mass",
        "most strained spring",
        "smaller",
        "--dt",
        "hooke check",
        "frames recorded before the error",
    ] {
        assert!(err.contains(needle), "`{needle}` missing from: {err}");
    }
    let frames = &read_rrd(&path)["/world/strand_0/masses"].0;
    assert!(
        !frames.is_empty() && frames.len() < 361,
        "{} frames recorded",
        frames.len()
    );
    assert_eq!(
        frames.iter().copied().max(),
        Some(frames.len() as i64 - 1),
        "frames missing"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bench_accuracy_writes_its_table_and_chart_and_finds_the_stable_step() {
    let dir = temp_dir("accuracy");
    let out = hooke(&[
        "bench",
        "accuracy",
        "hair",
        "--backend",
        "cpu",
        "--duration",
        "0.1",
        "--points",
        "3",
        "--coarsest",
        "0",
        "--out",
        &dir.to_string_lossy(),
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv =
        std::fs::read_to_string(dir.join("accuracy-hair.csv")).unwrap_or_else(|e| panic!("{e}"));
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 6 * 3, "six integrators × three steps:\n{csv}");
    // Semi-implicit Euler is first order: halving dt about halves the error.
    let semi: Vec<f64> = rows
        .iter()
        .filter(|r| r[1] == "semi-implicit")
        .map(|r| r[4].parse().unwrap_or(f64::NAN))
        .collect();
    for w in semi.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (1.6..2.5).contains(&ratio),
            "semi-implicit error ratio {ratio} ({semi:?})"
        );
    }
    // Forward Euler is far past its limit at these steps; implicit Euler is stable at all of
    // them, and its numerical damping shows as dissipated energy, not as instability.
    assert!(
        rows.iter()
            .filter(|r| r[1] == "euler")
            .all(|r| r[7] == "false"),
        "{csv}"
    );
    assert!(
        rows.iter()
            .filter(|r| r[1] == "implicit")
            .all(|r| r[7] == "true" && r[8].parse::<f64>().is_ok_and(|p| p > 0.0)),
        "{csv}"
    );
    // The search agrees with `hooke check`'s estimate for semi-implicit Euler within 10%.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("| semi-implicit | ") && l.matches('|').count() == 5)
        .unwrap_or_else(|| panic!("{stdout}"));
    let cells: Vec<f64> = line
        .split('|')
        .filter_map(|c| c.trim().trim_end_matches(" s").parse().ok())
        .collect();
    assert_eq!(cells.len(), 2, "{line}");
    assert!(
        (cells[1] / cells[0] - 1.0).abs() < 0.1,
        "estimate {} vs found {}",
        cells[0],
        cells[1]
    );
    // The guidance names, for each error level, the cheapest stable run that reached it.
    let num = |c: &str| c.parse::<f64>().unwrap_or(f64::NAN);
    let mut named = 0;
    for line in stdout.lines().filter(|l| l.starts_with("| 1e-")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let level = num(cells[1].trim_end_matches(" m"));
        let reaching: Vec<&Vec<&str>> = rows
            .iter()
            .filter(|r| r[7] == "true" && num(r[4]) <= level)
            .collect();
        let cheapest = reaching
            .iter()
            .map(|r| num(r[9]))
            .fold(f64::INFINITY, f64::min);
        if cells[2] == "none of the runs" {
            assert!(reaching.is_empty(), "{line}");
            continue;
        }
        named += 1;
        let row = reaching
            .iter()
            .find(|r| r[1] == cells[2] && (num(r[2]) / num(cells[3]) - 1.0).abs() < 1e-3)
            .unwrap_or_else(|| panic!("{line} names a run that does not reach it:\n{csv}"));
        assert_eq!(num(row[9]), cheapest, "{line}: not the cheapest\n{csv}");
    }
    assert!(named >= 2, "{stdout}");
    let svg =
        std::fs::read_to_string(dir.join("accuracy-hair.svg")).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        svg.starts_with("<svg") && svg.contains("polyline") && svg.trim_end().ends_with("</svg>")
    );
    assert!(dir.join("accuracy-hair.md").exists());
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn dt_auto_says_what_it_picked_and_a_tighter_tolerance_takes_more_substeps() {
    let substeps = |tolerance: &str| -> u32 {
        let out = hooke(&[
            "check",
            "hair",
            "--backend",
            "cpu",
            "--dt",
            "auto",
            "--tolerance",
            tolerance,
        ]);
        let err = text(&out.stderr);
        let out_text = text(&out.stdout);
        let line = out_text
            .lines()
            .chain(err.lines())
            .find(|l| l.starts_with("--dt auto: "))
            .unwrap_or_else(|| panic!("no --dt auto line:\n{out_text}\n{err}"));
        line["--dt auto: ".len()..]
            .split_whitespace()
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    let (loose, tight) = (substeps("1e-3"), substeps("1e-5"));
    assert!(
        tight > loose,
        "tolerance 1e-5 took {tight} substeps, 1e-3 took {loose}"
    );
    let out = hooke(&["check", "hair", "--dt", "fast"]);
    assert!(
        text(&out.stderr).contains("expected seconds (like 0.001) or `auto`"),
        "{}",
        text(&out.stderr)
    );
}

/// Ctrl-C (SIGINT) or SIGTERM during `--save`: the run stops, every frame already produced is in
/// the file, contiguous from frame 0, the file decodes to its end, and the exit status is 130.
#[test]
fn an_interrupted_recording_keeps_every_frame_it_produced() {
    for signal in ["-INT", "-TERM"] {
        let dir = temp_dir(&format!("signal{signal}"));
        let path = dir.join("cloth.rrd");
        let mut child = Command::new(env!("CARGO_BIN_EXE_hooke"))
            .args([
                "run",
                "cloth",
                "--backend",
                "cpu",
                "--duration",
                "600",
                "--save",
                &path.to_string_lossy(),
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("{e}"));
        // Wait until frames are being written.
        let started = std::time::Instant::now();
        while std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0) < 200_000 {
            assert!(
                started.elapsed().as_secs() < 60,
                "the run never started writing"
            );
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        let sent = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(sent.success());
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        let status = loop {
            if let Some(s) = child.try_wait().unwrap_or_else(|e| panic!("{e}")) {
                break s;
            }
            assert!(
                std::time::Instant::now() < deadline,
                "{signal}: the run did not stop"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let mut err = String::new();
        if let Some(mut e) = child.stderr.take() {
            let _ = std::io::Read::read_to_string(&mut e, &mut err);
        }
        assert_eq!(status.code(), Some(130), "{signal}: {err}");
        assert!(
            err.contains("interrupted:") && err.contains("saved"),
            "{signal}: {err}"
        );
        let frames = &read_rrd(&path)["/world/cloth/surface"].0;
        let n = frames.len() as i64;
        assert!(n > 1, "{signal}: only {n} frames");
        assert_eq!(
            frames.iter().copied().collect::<Vec<_>>(),
            (0..n).collect::<Vec<_>>(),
            "{signal}: frames missing"
        );
        assert!(
            err.contains(&format!("interrupted: {n} frames")),
            "{signal}: the summary should count the {n} frames saved: {err}"
        );
        let _ = std::fs::remove_dir_all(dir);
    }
}
