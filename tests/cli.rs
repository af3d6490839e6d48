//! The `hooke` binary end to end: scene listing, `check`, recordings read back with Rerun's own
//! decoder, a run with no viewer or no GPU, a diverging run and an interrupted one. Bad input is
//! in `cli_bad_input.rs`, the benchmarks in `cli_bench.rs`.

use crate::common;

use std::collections::BTreeSet;
use std::path::Path;

use crate::common::{
    cpu_run, file_size, hooke, hooke_command, read_rrd, save_cpu_run, temp_dir, text,
};

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

/// A command that only prints, its standard output closed before it writes (`hooke scenes |
/// head -0`), ends quietly, as a Unix filter does: no panic in `println!`.
#[cfg(unix)]
#[test]
fn printing_commands_end_quietly_when_their_output_is_closed() {
    use std::os::unix::process::ExitStatusExt as _;
    for args in [&["scenes"][..], &["check", "hair", "--backend", "cpu"][..]] {
        let (reader, writer) = std::io::pipe().unwrap_or_else(|e| panic!("a pipe: {e}"));
        drop(reader);
        let out = hooke_command(args)
            .stdout(std::process::Stdio::from(writer))
            .output()
            .unwrap_or_else(|e| panic!("cannot run hooke: {e}"));
        let stderr = text(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            out.status.success() || out.status.signal() == Some(13),
            "{args:?}: {:?}, {stderr}",
            out.status
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
    // The run's integrator is marked with the step it takes, not beside its limit alone.
    assert!(
        s.contains("<- this run: dt = 4.167e-4 s, 83% of the limit"),
        "{s}"
    );
    // Where each body's pins landed (the cloth's two top corners).
    let out = hooke(&["check", "cloth", "--backend", "cpu"]);
    assert!(
        text(&out.stdout).contains("pinned at (m): [-0.775, 1.200, 0.000], [0.775, 1.200, 0.000]"),
        "{}",
        text(&out.stdout)
    );
    // Far above the limit: a warning that says what to do.
    let out = hooke(&["check", "jello", "--substeps", "2"]);
    let s = text(&out.stdout);
    assert!(
        s.contains("warning: dt = ") && s.contains("substeps per frame"),
        "{s}"
    );
}

#[test]
fn a_recording_without_its_footer_still_holds_every_frame() {
    // --no-rrd-footer: for long runs, Rerun's file sink keeps no chunk index in memory.
    let dir = temp_dir("nofooter");
    let path = dir.join("hair.rrd");
    save_cpu_run("hair", 30, &path, &["--no-rrd-footer"]);
    let frames = &read_rrd(&path).frames["/world/strand_0/masses"];
    assert_eq!(frames, &(0..=30).collect::<BTreeSet<i64>>());
    // The same run with its footer is larger by the index.
    let indexed = dir.join("indexed.rrd");
    save_cpu_run("hair", 30, &indexed, &[]);
    assert!(
        file_size(&path) < file_size(&indexed),
        "no footer: {} bytes, with footer: {} bytes",
        file_size(&path),
        file_size(&indexed)
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn recordings_show_the_tear_and_every_collider() {
    let dir = temp_dir("effects");
    let frames = 70;
    for scene in ["tear", "ramp"] {
        let path = dir.join(format!("{scene}.rrd"));
        save_cpu_run(scene, frames, &path, &[]);
        let e = read_rrd(&path);
        let every: BTreeSet<i64> = (0..=frames as i64).collect();
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
            let got = e
                .frames
                .get(*entity)
                .unwrap_or_else(|| panic!("{scene}: no {entity}"));
            assert_eq!(got, &every, "{scene}: {entity} frames");
        }
        // Fixed colliders are logged once, static.
        if scene == "ramp" {
            for entity in ["/world/colliders/box_0", "/world/colliders/plane_0"] {
                let got = e
                    .frames
                    .get(entity)
                    .unwrap_or_else(|| panic!("no {entity}"));
                assert!(got.is_empty(), "{entity} is fixed: {got:?}");
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
        let missing = || panic!("{entity} missing; have {:?}", e.frames.keys());
        let f = e.frames.get(entity).unwrap_or_else(missing);
        let t = e.sim_time.get(entity).unwrap_or_else(missing);
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
        assert!(
            e.frames.contains_key(static_entity),
            "{static_entity} missing"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn with_no_viewer_the_run_records_to_a_file_and_says_so() {
    let dir = temp_dir("fallback");
    let out = hooke_command(&["run", "hair", "--backend", "cpu", "--frames", "3"])
        .current_dir(&dir)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("recording to hair.rrd instead") && err.contains("rerun hair.rrd"),
        "{err}"
    );
    let frames = &read_rrd(&dir.join("hair.rrd")).frames["/world/strand_0/masses"];
    assert_eq!(frames.len(), 4);
    let _ = std::fs::remove_dir_all(dir);
}

/// Each built-in scene's GPU step, as `hooke check` prints it: exactly the passes and compiled-in
/// effects its scene file asks for (one fused pass where the springs never change and no masses
/// collide with each other; for a small scene whose colliders stand still, one dispatch a
/// submission). A new built-in scene must be added here.
const SCENE_PASSES: &[(&str, &str, &str)] = &[
    ("hair", "fused_frame", "HAS_GRAVITY, HAS_DRAG, HAS_DAMPING"),
    (
        "cloth",
        "fused_frame",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_SPHERES, HAS_COLLIDERS, HAS_DAMPING",
    ),
    (
        "jello",
        "fused_frame",
        "HAS_GRAVITY, HAS_GROUND, HAS_DAMPING",
    ),
    (
        "jello-sphere",
        "fused_frame",
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
        "neighbours_build → compute_forces → collide_masses → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_DAMPING",
    ),
    (
        "pile",
        "neighbours_build → compute_forces → collide_masses → semi_implicit_update → project_contacts",
        "HAS_GRAVITY, HAS_GROUND, HAS_DAMPING",
    ),
    ("cloth-64", "fused_step", "HAS_GRAVITY, HAS_DAMPING"),
    ("cloth-256", "fused_step", "HAS_GRAVITY, HAS_DAMPING"),
    ("cloth-1024", "fused_step", "HAS_GRAVITY, HAS_DAMPING"),
    (
        "flag",
        "fused_frame",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_BOXES, HAS_COLLIDERS, HAS_DAMPING",
    ),
    (
        "tablecloth",
        "fused_step",
        "HAS_GRAVITY, HAS_DRAG, HAS_GROUND, HAS_BOXES, HAS_COLLIDERS, HAS_DAMPING",
    ),
    ("blob", "fused_step", "HAS_GRAVITY, HAS_GROUND, HAS_DAMPING"),
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
    // Mass–mass contact is listed among the effects, with its rule, its pair damping and its
    // neighbour lists' reach (3 r) and rebuild distance (0.3 r).
    let s = text(&hooke(&["check", "pile", "--backend", "cpu"]).stdout);
    assert!(
        s.contains("self-collision (between bodies only): radius 0.02 m, stiffness 1000 N/m per pair, friction 0.5"),
        "pile:\n{s}"
    );
    let s = text(&hooke(&["check", "cloth-fold", "--backend", "cpu"]).stdout);
    assert!(
        s.contains("self-collision (within and between bodies): radius 0.018 m")
            && s.contains("neighbour lists of the masses within 0.0540 m, rebuilt once a mass has moved 0.0054 m"),
        "cloth-fold:\n{s}"
    );
    // A fused scene says why it does not step a submission in one workgroup, and how many of
    // its masses take a grid stencil.
    let s = text(&hooke(&["check", "cloth-64", "--backend", "cpu"]).stdout);
    assert!(
        s.contains("a dispatch per step, not one a submission: 4096 masses, more than one workgroup steps on a GPU (1024)")
            && s.contains("grid stencils: 4096 of 4096 masses (1 grid body)"),
        "cloth-64:\n{s}"
    );
    // A scene's integrator changes the force and update passes, not the effects' passes.
    let out = hooke(&["check", "tear", "--integrator", "rk2", "--backend", "cpu"]);
    let s = text(&out.stdout);
    assert!(s.contains(
        "GPU step passes: compute_forces → rk2_stage → compute_forces → rk2_final → project_contacts → update_springs\n"
    ));
    assert!(
        s.contains("not the fused step: rk2 has no fused step\n"),
        "{s}"
    );
    // Fused: Verlet in two passes, RK4 in one per stage.
    for (integrator, passes) in [
        ("verlet", "fused_verlet_drift → fused_verlet_kick"),
        (
            "rk4",
            "fused_rk4_begin → fused_rk4_mid → fused_rk4_mid → fused_rk4_final",
        ),
    ] {
        let out = hooke(&[
            "check",
            "jello",
            "--integrator",
            integrator,
            "--backend",
            "cpu",
        ]);
        let s = text(&out.stdout);
        assert!(
            s.contains(&format!("GPU step passes: {passes}\n")) && !s.contains("not the fused"),
            "jello {integrator}:\n{s}"
        );
    }
    // Implicit Euler: Newton iterations, each a conjugate-gradient solve, then the update; a small
    // system's whole step in one workgroup's dispatch, a larger one's a dispatch per pass, two per
    // CG iteration and, from 4 096 masses whose springs are stiff against the step, a multigrid
    // cycle over the coarse levels (the 64 × 64 peer cloth's four at 1/60 s: 1 024, 256, 64 and
    // 16 nodes) before each cg_apply. cloth-64 at its own step takes block Jacobi.
    let cloth_64 = "implicit_begin → solver_begin → [Newton: implicit_iterate → forces_and_rhs → \
         cg_begin → cg_apply → [CG: cg_advance → cg_apply] → newton_update → newton_end] → \
         implicit_final";
    let cycle =
        "[cycle: mg_fine_down → mg_restrict × 4 → mg_solve_coarsest → mg_prolong × 3 → mg_fine_up]";
    let peer_64 = format!(
        "implicit_begin → solver_begin → [Newton: implicit_iterate → forces_and_rhs → cg_begin → \
         [levels: mg_linearise → mg_invert] × 4 → mg_factor → {cycle} → cg_apply → \
         [CG: cg_advance → {cycle} → cg_apply] → newton_update → newton_end] → implicit_final"
    );
    for (scene, passes) in [
        (
            "hair",
            "implicit_step (one workgroup, the whole step: [Newton: iterate → forces → [CG]])",
        ),
        ("cloth-64", cloth_64),
        ("bench/scenes/peer-cloth-64-60hz.toml", peer_64.as_str()),
    ] {
        let out = hooke(&[
            "check",
            scene,
            "--integrator",
            "implicit",
            "--backend",
            "cpu",
        ]);
        let s = text(&out.stdout);
        assert!(
            s.contains(&format!("GPU step passes: {passes}\n")),
            "{scene}, implicit:\n{s}"
        );
    }
}

#[test]
fn the_guide_scene_example_is_a_valid_scene() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide/scenes.md"))
            .unwrap_or_else(|e| panic!("{e}"));
    let start = readme
        .find("```toml\n")
        .unwrap_or_else(|| panic!("no toml block in docs/guide/scenes.md"))
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
    let out = hooke_command(&[
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
    // Forward Euler at the hair scene's dt is 20 times past what its dashpots allow.
    let out = hooke(&cpu_run(
        "hair",
        &["--integrator", "euler", "--save", &path.to_string_lossy()],
    ));
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
    let frames = &read_rrd(&path).frames["/world/strand_0/masses"];
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
    // No NaN or infinity reached the file: the diverged step's state was never handed out.
    common::verified_rrd(&path);
    let _ = std::fs::remove_dir_all(dir);
}

/// A step above the estimate is named before anything steps, by `check` and by `run` alike: the
/// limit (stiffness here), the mass, the spring kind, and the step that would hold.
#[test]
fn a_step_above_the_estimate_is_named_before_stepping() {
    let dir = temp_dir("above");
    let path = dir.join("hair.rrd");
    let path = path.to_string_lossy();
    let check = hooke(&["check", "hair", "--backend", "cpu", "--dt", "2e-3"]);
    let run = hooke(&cpu_run(
        "hair",
        &["--dt", "2e-3", "--frames", "1", "--save", &path],
    ));
    for (what, out) in [("check", &check), ("run", &run)] {
        let all = text(&out.stdout) + &text(&out.stderr);
        let warning = all
            .lines()
            .find(|l| l.starts_with("warning: dt = "))
            .unwrap_or_else(|| panic!("{what} gave no warning: {all}"));
        for needle in [
            "above the estimated stable step 1.368e-3 s",
            "stiffness limit",
            "structural springs at mass",
            "--dt 1.368e-3",
        ] {
            assert!(
                warning.contains(needle),
                "{what}: `{needle}` missing from: {warning}"
            );
        }
    }
    // `run` says it before its first frame.
    let err = text(&run.stderr);
    let warned = err.find("warning: dt = ").unwrap_or(usize::MAX);
    let started = err.find("hooke: 'hair'").unwrap_or(0);
    assert!(
        warned < started,
        "the warning should come before the run starts: {err}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// The same divergence on the GPU backend (lavapipe here): the device flags the bad step, the
/// frame is never read back as good, and the file holds no NaN or infinity.
#[test]
fn a_diverging_gpu_run_records_no_non_finite_value() {
    if !common::gpu_available() {
        return;
    }
    let dir = temp_dir("diverge-gpu");
    let path = dir.join("hair.rrd");
    let out = hooke(&[
        "run",
        "hair",
        "--backend",
        "gpu",
        "--integrator",
        "euler",
        "--save",
        &path.to_string_lossy(),
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    // On the GPU the ledger's runaway (solver_watch's RUNAWAY_SHARE, checked once a frame) may
    // stop this run before its state crosses the runaway speed, which the CPU's step
    // finds first.
    assert!(
        err.contains("diverged at step") || err.contains("the integrator is making energy"),
        "{err}"
    );
    common::verified_rrd(&path);
    let _ = std::fs::remove_dir_all(dir);
}

/// Ctrl-C (SIGINT) or SIGTERM during `--save`: the run stops, every frame already produced is in
/// the file, contiguous from frame 0, the file decodes to its end, and the exit status is 130.
#[test]
fn an_interrupted_recording_keeps_every_frame_it_produced() {
    for signal in ["-INT", "-TERM"] {
        let dir = temp_dir(&format!("signal{signal}"));
        let path = dir.join("cloth.rrd");
        let run = common::Running::start(&cpu_run(
            "cloth",
            &["--duration", "600", "--save", &path.to_string_lossy()],
        ));
        // Wait until frames are being written: to the partial file, which takes the file's
        // name when the run ends.
        let partial = dir.join("cloth.rrd.partial");
        common::wait_for(
            || file_size(&partial) >= 200_000,
            "the run to start writing",
        );
        run.signal(signal);
        let (code, err) = run.finish();
        assert_eq!(code, Some(130), "{signal}: {err}");
        assert!(
            err.contains("interrupted:") && err.contains("saved"),
            "{signal}: {err}"
        );
        assert!(!partial.exists(), "{signal}: the partial file was left");
        let frames = &common::verified_rrd(&path).frames["/world/cloth/surface"];
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

/// The README stays a page a newcomer reads in two minutes (at most 200 lines: the rest is in
/// docs/guide/), and every relative link in it and in the guide names a file that exists.
#[test]
fn the_readme_is_short_and_its_links_and_the_guides_resolve() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        readme.lines().count() <= 200,
        "README.md has {} lines: move the detail into docs/guide/",
        readme.lines().count()
    );
    let pages = documented_pages();
    assert!(pages.len() > 5, "the guide's pages: {pages:?}");
    for page in pages {
        let text = std::fs::read_to_string(&page).unwrap_or_else(|e| panic!("{e}"));
        let dir = page.parent().unwrap_or(root);
        for link in text.split("](").skip(1) {
            let target = link.split([')', '#']).next().unwrap_or("");
            if target.is_empty() || target.starts_with("http") {
                continue;
            }
            assert!(
                dir.join(target).exists(),
                "{}: the link to {target} names no file",
                page.display()
            );
        }
    }
}

/// Every sample in the README and the guide that names its command (a fenced block whose first
/// line is `$ hooke ARGS`) is what that command prints now: the block's text, its lines joined,
/// appears in the command's output, whitespace aside (the docs wrap what the program prints on
/// one line). A run's files go to a temporary folder.
#[test]
fn documented_samples_are_what_the_commands_print() {
    let words = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    let dir = temp_dir("samples");
    let mut samples = 0;
    for page in documented_pages() {
        let doc = std::fs::read_to_string(&page).unwrap_or_else(|e| panic!("{e}"));
        for block in doc.split("```").skip(1).step_by(2) {
            // The fence's info string, then the command.
            let mut lines = block.lines().skip(1);
            let Some(args) = lines.next().and_then(|l| l.strip_prefix("$ hooke ")) else {
                continue;
            };
            let expected = words(&lines.collect::<Vec<_>>().join("\n"));
            let out = hooke_command(&args.split_whitespace().collect::<Vec<_>>())
                .current_dir(&*dir)
                .output()
                .unwrap_or_else(|e| panic!("{e}"));
            let printed = words(&format!("{}{}", text(&out.stdout), text(&out.stderr)));
            assert!(
                printed.contains(&expected),
                "{}: `hooke {args}` no longer prints the sample\n{expected}\nbut\n{printed}",
                page.display()
            );
            samples += 1;
        }
    }
    assert!(samples >= 3, "only {samples} samples name their command");
}

/// The README and the guide's pages.
fn documented_pages() -> Vec<std::path::PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let guide = std::fs::read_dir(root.join("docs/guide")).unwrap_or_else(|e| panic!("{e}"));
    let mut pages = vec![root.join("README.md")];
    pages.extend(guide.filter_map(|e| e.ok().map(|e| e.path())));
    pages
}

/// `run --help` says what `--save` does here: beside `--connect` it records as well as streams,
/// where Rerun's own help says it saves "rather than visualizing".
#[test]
fn run_help_says_save_beside_connect_records_and_streams() {
    let out = common::ok(common::hooke_command(&["run", "--help"]).output());
    let help = text(&out.stdout);
    assert!(out.status.success(), "{help}");
    assert!(
        help.contains("beside --connect, as well as streaming to that viewer"),
        "{help}"
    );
    assert!(!help.contains("rather than visualizing"), "{help}");
}
