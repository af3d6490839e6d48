//! `hooke sweep`: sweep files and their errors, a local sweep's results (convergence orders
//! included), the same points through a real Slurm cluster bit for bit, a Slurm task killed
//! mid-point and resumed, and the recordings served by `rerun server -d` as one dataset.
//!
//! The Slurm tests need `sbatch` and a cluster that answers (`bash .ci/slurm.sh` starts a
//! one-node one). Without them they say so and pass, unless `HOOKE_REQUIRE_SLURM=1` (set by
//! `.ci/run`) makes a missing Slurm a failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use hooke::sweep::result::{PointResult, Status};

use crate::common::{hooke, temp_dir, text};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

const SMALL: &str = "examples/sweeps/a-small-grid.toml";

fn results(dir: &Path, n: usize) -> Vec<PointResult> {
    (0..n)
        .map(|i| {
            let path = dir.join(format!("points/{i:04}/result.json"));
            hooke::sweep::result::read(&path)
                .unwrap_or_else(|| panic!("no result at {}", path.display()))
        })
        .collect()
}

fn run_ok(args: &[&str]) -> String {
    let out = hooke(args);
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "hooke {args:?} failed:\n{said}");
    said
}

/// `hooke sweep run FILE --out OUT EXTRA…`, which must succeed: what it said.
fn sweep_run(file: &str, out: &str, extra: &[&str]) -> String {
    let mut args = vec!["sweep", "run", file, "--out", out];
    args.extend_from_slice(extra);
    run_ok(&args)
}

/// Whether a Slurm cluster answers here; a missing one fails under `HOOKE_REQUIRE_SLURM=1`.
pub(crate) fn slurm_here(test: &str) -> bool {
    let answers = Command::new("sinfo")
        .args(["-h", "-o", "%T"])
        .output()
        .is_ok_and(|o| o.status.success() && !o.stdout.is_empty());
    if !answers {
        assert!(
            std::env::var_os("HOOKE_REQUIRE_SLURM").is_none_or(|v| v != "1"),
            "{test}: no Slurm cluster answers `sinfo` here, and HOOKE_REQUIRE_SLURM=1 requires one: `bash .ci/slurm.sh` starts a one-node cluster"
        );
        eprintln!("{test}: skipped: no Slurm cluster here (`bash .ci/slurm.sh` starts one)");
    }
    answers
}

#[test]
fn a_sweep_file_that_cannot_be_run_is_one_message_naming_its_line() {
    let dir = temp_dir("sweep-bad");
    std::fs::copy(
        repo("examples/sweeps/cloth-16.toml"),
        dir.join("cloth-16.toml"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let cases: &[(&str, &str)] = &[
        (
            "scene = \"cloth-16.toml\"\n[axes]\n\"bodies.hat.mass_kg\" = [1.0]\n",
            ":3:25: bodies.hat.mass_kg: 'bodies' has no element named 'hat': it has cloth",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\n\"bodies.cloth.mass_kg\" = [1.0, \"heavy\"]\n",
            ":3:32: bodies.cloth.mass_kg = \"heavy\": bodies[0].mass_kg: invalid type: string",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\nintegrator = []\n",
            ":3:1: axis 'integrator' is empty",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\nintegrator = [\"rk5\"]\n",
            ":3:15: integrator = \"rk5\" is not one of",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\ndt_secs = 1e-4\n",
            ":3:1: axis 'dt_secs' is one value",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\n\"bodies.cloth.spring_colour\" = [1.0]\n",
            ":3:33: bodies.cloth.spring_colour = 1.0: bodies[0].spring_colour: unknown field",
        ),
        (
            "scene = \"cloth-16.toml\"\n[axes]\n\"bodies.cloth.mass_kg\" = [-1.0]\n",
            ":3:27: bodies.cloth.mass_kg = -1.0: bodies[0].mass_kg: must be greater than zero",
        ),
        (
            "scene = \"cloth-17.toml\"\n",
            ":1:1: scene = \"cloth-17.toml\" is neither a built-in scene",
        ),
        (
            "scene = \"cloth-16.toml\"\nrepeats = 3\n",
            ":2:1: unknown field `repeats`",
        ),
    ];
    for (i, (body, wanted)) in cases.iter().enumerate() {
        let file = dir.join(format!("bad-{i}.toml"));
        std::fs::write(&file, body).unwrap_or_else(|e| panic!("{e}"));
        let out = hooke(&["sweep", "plan", &file.to_string_lossy()]);
        let said = text(&out.stderr);
        assert!(!out.status.success(), "case {i} was accepted:\n{body}");
        assert!(
            said.starts_with(&format!("error: {}", file.display())) && said.contains(wanted),
            "case {i}: wanted '{wanted}' after the file's name, got: {said}"
        );
        assert_eq!(said.trim().lines().count(), 1, "case {i}: one line: {said}");
    }
}

#[test]
fn a_local_sweep_converges_at_each_integrators_order_and_writes_its_report() {
    let dir = temp_dir("sweep-local");
    let out = dir.join("sweep");
    let plan = run_ok(&["sweep", "plan", &repo(SMALL).to_string_lossy()]);
    assert!(
        plan.contains("8 points varying integrator, dt_secs, bodies.cloth.springs.structural.stiffness_n_per_m"),
        "{plan}"
    );
    sweep_run(&repo(SMALL).to_string_lossy(), &out.to_string_lossy(), &[]);
    let r = results(&out, 8);
    assert!(r.iter().all(|p| p.status == Status::Ok), "{r:#?}");
    // Grid order: integrator slowest, then dt (1/1200, 1/600), then stiffness. Halving the step
    // halves semi-implicit Euler's error (first order) and quarters Verlet's (second order).
    for k in 0..2 {
        let ratio = |fine: usize, coarse: usize| {
            r[coarse].error_rms_m.unwrap_or(f64::NAN) / r[fine].error_rms_m.unwrap_or(f64::NAN)
        };
        let first = ratio(k, 2 + k);
        let second = ratio(4 + k, 6 + k);
        assert!((1.7..2.3).contains(&first), "semi-implicit: ×{first}");
        assert!((3.4..4.6).contains(&second), "verlet: ×{second}");
    }
    // The digest is the end state's: the same scene stepped by the library directly ends alike.
    let scene = std::fs::read_to_string(out.join("points/0000/scene.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let origin = hooke::scene::SceneOrigin::File(repo("examples/sweeps/cloth-16.toml"));
    let scene = crate::common::ok(hooke::scene::from_toml(&scene, origin));
    let settings = crate::common::ok(hooke::scene::settings::Settings::resolve(
        &scene,
        &Default::default(),
    ));
    let model = std::sync::Arc::new(hooke::model::build(&scene));
    let mut be =
        crate::common::ok(hooke::run::select::Device::cpu().create(model, settings.step()));
    crate::common::ok(hooke::backend::advance_steps(
        be.as_mut(),
        settings.frames * u64::from(settings.substeps),
        7,
    ));
    let digest = format!("{:016x}", crate::common::ok(be.state()).digest());
    assert_eq!(r[0].digest.as_deref(), Some(digest.as_str()));
    for i in 0..8 {
        crate::common::verified_rrd(&out.join(format!("points/{i:04}.rrd")));
    }
    run_ok(&["sweep", "report", &out.to_string_lossy()]);
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(csv.lines().count(), 9, "{csv}");
    assert!(
        csv.lines().nth(1).is_some_and(|l| l.contains(&digest)),
        "{csv}"
    );
    let svg = std::fs::read_to_string(out.join("results.svg")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(svg.matches("<circle").count(), 8, "{svg}");
    let status = run_ok(&["sweep", "status", &out.to_string_lossy()]);
    assert!(status.contains("8 points: 8 ok"), "{status}");
    served_as_one_dataset(&out, 8);
}

/// `rerun server -d DIR/points` loads the `n` recordings as the segments of one dataset, each
/// named by its point (`PLAN_ID-NNNN`).
fn served_as_one_dataset(out: &Path, n: usize) {
    let plan = crate::common::ok(hooke::sweep::plan::read(out));
    let port = crate::common::free_port().to_string();
    let mut server = Command::new(crate::common::rerun_cli())
        .args(["server", "-p", &port, "-d"])
        .arg(out.join("points"))
        .env("RUST_LOG", "debug")
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("rerun server: {e}"));
    // Its log goes to standard error; the server runs until killed.
    let log = server.stderr.take().unwrap_or_else(|| panic!("no stdout"));
    let mut seen = String::new();
    for line in std::io::BufRead::lines(std::io::BufReader::new(log)).map_while(Result::ok) {
        seen.push_str(&line);
        seen.push('\n');
        if line.contains("Finished loading") {
            break;
        }
    }
    let _ = server.kill();
    let _ = server.wait();
    assert!(seen.contains("create_dataset name=points"), "{seen}");
    for i in 0..n {
        let segment = format!("SegmentId {{ id: \"{}-{i:04}\" }}", plan.id);
        assert_eq!(seen.matches(&segment).count(), 1, "{segment} in:\n{seen}");
    }
}

#[test]
fn a_slurm_sweep_ends_bit_for_bit_where_the_local_one_does() {
    if !slurm_here("a_slurm_sweep_ends_bit_for_bit_where_the_local_one_does") {
        return;
    }
    let dir = temp_dir("sweep-slurm");
    let (local, slurm) = (dir.join("local"), dir.join("slurm"));
    let file = repo(SMALL).to_string_lossy().into_owned();
    sweep_run(&file, &local.to_string_lossy(), &[]);
    let said = sweep_run(&file, &slurm.to_string_lossy(), &["--on", "slurm"]);
    assert!(said.contains("submitted Slurm job"), "{said}");
    let script =
        std::fs::read_to_string(slurm.join("slurm/array.sh")).unwrap_or_else(|e| panic!("{e}"));
    assert!(script.contains("#SBATCH --array=0-7\n"), "{script}");
    let (a, b) = (results(&local, 8), results(&slurm, 8));
    for (a, b) in a.iter().zip(&b) {
        assert_eq!(b.status, Status::Ok, "{b:#?}");
        assert!(a.digest.is_some());
        assert_eq!(a.digest, b.digest, "point {}", a.index);
        assert_eq!(a.error_rms_m, b.error_rms_m, "point {}", a.index);
    }
}

/// `squeue`'s state of task `index` of `job`, if it is queued.
fn task_state(job: &str, index: usize) -> Option<String> {
    let out = Command::new("squeue")
        .args(["-h", "-r", "-j", job, "-o", "%i %T"])
        .output()
        .ok()?;
    text(&out.stdout)
        .lines()
        .find(|l| l.starts_with(&format!("{job}_{index} ")))
        .map(|l| l.split_whitespace().nth(1).unwrap_or("").to_owned())
}

#[test]
fn a_slurm_task_killed_mid_point_leaves_no_result_and_resume_completes_the_sweep() {
    if !slurm_here("a_slurm_task_killed_mid_point_leaves_no_result_and_resume_completes_the_sweep")
    {
        return;
    }
    let dir = temp_dir("sweep-kill");
    // Long enough to be caught running: seconds of RK4 on the 16 × 16 cloth.
    let file = dir.join("long.toml");
    std::fs::write(
        &file,
        format!(
            "scene = \"{}\"\n[set]\nbackend = \"cpu\"\n\"solver.duration_secs\" = 6.0\n[axes]\nintegrator = [\"rk4\", \"verlet\"]\ndt_secs = [\"1/6000\"]\n",
            repo("examples/sweeps/cloth-16.toml").display()
        ),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("sweep");
    let said = sweep_run(
        &file.to_string_lossy(),
        &out.to_string_lossy(),
        &["--on", "slurm", "--detach"],
    );
    let job = said
        .split("submitted Slurm job ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap_or_else(|| panic!("no job id in: {said}"))
        .to_owned();
    // Kill point 0 once it is under way (its `running` file is written as it starts).
    let deadline = Instant::now() + Duration::from_secs(120);
    while !(task_state(&job, 0).as_deref() == Some("RUNNING")
        && out.join("points/0000/running").exists())
    {
        assert!(Instant::now() < deadline, "point 0 never ran: {said}");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(500));
    let killed = Command::new("scancel")
        .arg(format!("{job}_0"))
        .stdout(Stdio::null())
        .status()
        .unwrap_or_else(|e| panic!("scancel: {e}"));
    assert!(killed.success());
    let deadline = Instant::now() + Duration::from_secs(300);
    while task_state(&job, 0).is_some() || task_state(&job, 1).is_some() {
        assert!(Instant::now() < deadline, "the job never ended");
        std::thread::sleep(Duration::from_millis(200));
    }
    assert!(
        !out.join("points/0000/result.json").exists(),
        "a killed point left a result"
    );
    let status = run_ok(&["sweep", "status", &out.to_string_lossy()]);
    assert!(status.contains("missing"), "{status}");
    let resumed = run_ok(&["sweep", "resume", &out.to_string_lossy(), "--on", "slurm"]);
    assert!(resumed.contains("resuming 1 of 2 points"), "{resumed}");
    let r = results(&out, 2);
    assert!(r.iter().all(|p| p.status == Status::Ok), "{r:#?}");
    // Nothing partial or doubled is left: one result and one recording a point.
    let mut names: Vec<String> = walk(&out.join("points"));
    names.sort();
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
    assert_eq!(
        names.iter().filter(|n| n.ends_with("result.json")).count(),
        2,
        "{names:?}"
    );
    assert_eq!(
        names.iter().filter(|n| n.ends_with(".rrd")).count(),
        2,
        "{names:?}"
    );
    crate::common::verified_rrd(&out.join("points/0000.rrd"));
    let status = run_ok(&["sweep", "status", &out.to_string_lossy()]);
    assert!(status.contains("2 points: 2 ok"), "{status}");
}

fn walk(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .flatten()
    {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p.to_string_lossy().into_owned());
        }
    }
    out
}

#[test]
fn the_readmes_sweep_file_is_one_hooke_plans() {
    let readme = std::fs::read_to_string(repo("README.md")).unwrap_or_else(|e| panic!("{e}"));
    let block = readme
        .split("```toml\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .unwrap_or_else(|| panic!("no toml block in README.md"));
    let dir = temp_dir("sweep-readme");
    let file = dir.join("readme.toml");
    std::fs::write(&file, block).unwrap_or_else(|e| panic!("{e}"));
    let plan = run_ok(&["sweep", "plan", &file.to_string_lossy()]);
    assert!(plan.contains("sweep of 'cloth-64': 4 points"), "{plan}");
}

#[test]
fn a_submission_slurm_refuses_is_one_message_in_slurms_words() {
    if !slurm_here("a_submission_slurm_refuses_is_one_message_in_slurms_words") {
        return;
    }
    let out = temp_dir("sweep-refused").join("sweep");
    let said = hooke(&[
        "sweep",
        "run",
        &repo(SMALL).to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--on",
        "slurm",
        "--partition",
        "no-such-partition",
    ]);
    let err = text(&said.stderr);
    assert!(!said.status.success());
    assert!(
        err.contains("error: Slurm refused the sweep's job: `sbatch --parsable")
            && err.contains("sbatch: error:")
            && err.to_lowercase().contains("partition"),
        "{err}"
    );
    // Nothing ran, and a resume may submit it again once the partition is right.
    let status = run_ok(&["sweep", "status", &out.to_string_lossy()]);
    assert!(status.contains("8 points: 8 missing"), "{status}");
}

#[test]
fn what_a_point_was_told_stays_with_its_result() {
    let dir = temp_dir("sweep-notes");
    let file = dir.join("notes.toml");
    // 1/740 s does not divide the frame: the run rounds it, and says so. 1/720 s is just above
    // semi-implicit Euler's estimated stable step on the hair: the run warns.
    std::fs::write(
        &file,
        "scene = \"hair\"\n[set]\nbackend = \"cpu\"\n\"solver.duration_secs\" = 0.25\n[axes]\ndt_secs = [\"1/740\", \"1/720\"]\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("sweep");
    let said = sweep_run(&file.to_string_lossy(), &out.to_string_lossy(), &[]);
    assert!(said.contains("ok, with 1 note(s)"), "{said}");
    let r = results(&out, 2);
    assert!(
        r[0].notes
            .iter()
            .any(|n| n.contains("does not divide the frame")),
        "{:?}",
        r[0].notes
    );
    assert!(
        r[1].notes
            .iter()
            .any(|n| n.contains("above the estimated stable step")),
        "{:?}",
        r[1].notes
    );
    run_ok(&["sweep", "report", &out.to_string_lossy()]);
    let md = std::fs::read_to_string(out.join("results.md")).unwrap_or_else(|e| panic!("{e}"));
    assert!(md.contains("ok, 1 note(s): note: dt ="), "{md}");
}
