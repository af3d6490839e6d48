//! Side-by-side comparisons (`hooke run --compare`): the gap to the reference is zero for an
//! entry that repeats it and grows with an explicit entry's step; an entry that diverges stops
//! alone while the others run to the end; every copy, gap and plot is in the one recording; a
//! scene's `[compare]` table runs as `--compare` does; and bad entries get one clear error each,
//! before anything runs.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::common::{hooke, ok, read_rrd, temp_dir, text};
use hooke::record::{ColourBy, CompareLayout};
use hooke::run::comparison::{ComparisonSummary, run_comparison};
use hooke::run::prepare::{Request, prepare_comparison};
use hooke::run::select::Device;
use hooke::scene::compare_entry::CompareEntry;
use hooke::scene::settings::Overrides;

/// `scene` compared under `entries` on the CPU backend for `frames` frames, into a recording
/// that goes nowhere.
fn compare(scene: &str, entries: &str, frames: u64) -> ComparisonSummary {
    let entries: Vec<CompareEntry> = CompareEntry::parse_list(entries)
        .unwrap_or_else(|(i, t, e)| panic!("entry {i} '{t}': {e}"));
    let request = Request {
        overrides: Overrides {
            frames: Some(frames),
            ..Overrides::default()
        },
        ..Request::named(scene, Device::cpu())
    };
    let prepared = ok(prepare_comparison(&request, &entries, &mut |_| {}));
    let layout = CompareLayout {
        overlay: false,
        gap_range_m: CompareLayout::default_gap_range(&prepared.model),
        colour_by: ColourBy::Gap,
    };
    let opts = hooke::run::RunOptions::unattended(None);
    ok(run_comparison(
        prepared,
        rerun::RecordingStream::disabled(),
        &opts,
        layout,
        Arc::new(AtomicBool::new(false)),
    ))
}

#[test]
fn an_entry_that_repeats_the_reference_has_no_gap() {
    let s = compare("hair", "semi-implicit,semi-implicit", 30);
    assert_eq!(s.entries.len(), 2);
    let names: Vec<&str> = s.entries.iter().map(|e| e.tally.name.as_str()).collect();
    assert_eq!(names, ["semi-implicit", "semi-implicit_2"], "unique names");
    let second = &s.entries[1];
    assert!(second.stopped.is_none());
    assert_eq!(
        second.tally.last_gap_rms_m,
        Some(0.0),
        "bit for bit the reference"
    );
    assert!(
        (second.tally.sim_secs - 0.5).abs() < 1e-6,
        "{}",
        second.tally.sim_secs
    );
}

#[test]
fn the_gap_grows_with_an_explicit_entrys_step() {
    // Semi-implicit Euler is first order: against a reference at a quarter of the finest step,
    // each doubling of the step should roughly double the gap.
    let s = compare(
        "hair",
        "semi-implicit@1/9600,semi-implicit@1/4800,semi-implicit@1/2400,semi-implicit@1/1200",
        30,
    );
    let gaps: Vec<f64> = s.entries[1..]
        .iter()
        .map(|e| e.tally.last_gap_rms_m.unwrap_or(f64::NAN))
        .collect();
    assert!(gaps[0] > 0.0, "{gaps:?}");
    for w in gaps.windows(2) {
        assert!(w[1] > 1.5 * w[0], "gaps {gaps:?} do not grow with the step");
    }
}

#[test]
fn a_diverging_entry_stops_alone_and_the_others_run_to_the_end() {
    // Forward Euler at the scene's step: no step is stable for sure on hair, and this one is
    // twenty times the dashpots' line. It is warned about, not refused, and it diverges.
    let s = compare("hair", "semi-implicit,euler,rk4", 60);
    let euler = &s.entries[1];
    let Some((frame, why)) = &euler.stopped else {
        panic!("euler at 1/1200 s ran to the end");
    };
    assert!(*frame < 60, "stopped at frame {frame}");
    // Its state runs away, or before that its ledger does (solver_watch's RUNAWAY_SHARE): it
    // doubles the energy it held within two frames.
    assert!(
        matches!(
            why,
            hooke::backend::BackendError::Diverged(_) | hooke::backend::BackendError::Unphysical(_)
        ),
        "{why}"
    );
    for e in [&s.entries[0], &s.entries[2]] {
        assert!(e.stopped.is_none(), "{} stopped", e.tally.name);
        assert!(
            (e.tally.sim_secs - 1.0).abs() < 1e-6,
            "{}",
            e.tally.sim_secs
        );
    }
    assert_eq!(s.frames_recorded, 61, "every frame recorded");
    assert!(s.entries[2].tally.last_gap_rms_m.is_some_and(|g| g > 0.0));
    let line = euler.line(false);
    assert!(line.contains("stopped at frame"), "{line}");
}

#[test]
fn a_comparison_records_every_copy_its_gap_and_the_plots() {
    let dir = temp_dir("compare-rrd");
    let path = dir.join("c.rrd");
    let out = hooke(&[
        "run",
        "cloth",
        "--backend",
        "cpu",
        "--frames",
        "6",
        "--compare",
        "semi-implicit,rk4",
        "--save",
        &path.to_string_lossy(),
    ]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("compared under 2 entries (side by side)"),
        "{err}"
    );
    for name in ["semi-implicit", "rk4"] {
        assert!(
            err.lines()
                .any(|l| l.trim_start().starts_with(name) && l.contains("wall-s per simulated s")),
            "no summary line for {name}: {err}"
        );
    }
    let r = read_rrd(&path);
    let all: Vec<i64> = (0..=6).collect();
    for entity in [
        "/world/semi-implicit/cloth/surface",
        "/world/rk4/cloth/surface",
        "/world/rk4/cloth/gap",
        "/compare/gap_rms/rk4",
        "/compare/gap_max/rk4",
        "/compare/energy_total/semi-implicit",
        "/compare/energy_balance/rk4",
        "/semi-implicit/energy/total",
    ] {
        assert_eq!(r.frames_of(entity), all, "{entity}");
    }
    // Frame 1's wall time (one-off costs in it) sits beside the plot, and frame 0, which took
    // no step, has none to plot.
    assert_eq!(
        r.frames_of("/compare/wall_ms/semi-implicit"),
        [2, 3, 4, 5, 6]
    );
    assert!(
        r.frames_of("/world/semi-implicit/cloth/gap").is_empty(),
        "the reference has no gap"
    );
}

#[test]
fn a_scenes_compare_table_runs_as_compare_does_and_its_entries_are_checked() {
    let dir = temp_dir("compare-table");
    let scene = dir.join("pair.toml");
    let base = ok(std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/hair.toml"
    )));
    ok(std::fs::write(
        &scene,
        format!("{base}\n[compare]\nentries = [\"semi-implicit\", \"verlet\"]\noverlay = true\n"),
    ));
    let path = dir.join("t.rrd");
    let out = hooke(&[
        "run",
        &scene.to_string_lossy(),
        "--backend",
        "cpu",
        "--frames",
        "3",
        "--save",
        &path.to_string_lossy(),
    ]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("compared under 2 entries (overlaid)"), "{err}");
    assert_eq!(
        read_rrd(&path).frames_of("/compare/gap_rms/verlet"),
        [0, 1, 2, 3]
    );

    let bad = dir.join("bad.toml");
    ok(std::fs::write(
        &bad,
        format!("{base}\n[compare]\nentries = [\"rk4\", \"rk9\"]\n"),
    ));
    let out = hooke(&["check", &scene.to_string_lossy(), "--backend", "cpu"]);
    let said = text(&out.stdout);
    assert!(
        said.contains(
            "compare: `hooke run` records this scene under semi-implicit, verlet, overlaid"
        ),
        "{said}"
    );
    let out = hooke(&["check", &bad.to_string_lossy()]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("compare.entries[1]") && err.contains("'rk9' names no integrator"),
        "{err}"
    );
}

#[test]
fn bad_compare_entries_get_one_clear_error_each_before_anything_runs() {
    let cases: [(&[&str], &str); 8] = [
        (
            &["--compare", "rk5"],
            "--compare entry 1 ('rk5'): 'rk5' names no integrator: use one of euler",
        ),
        (
            &["--compare", "rk4,,xpbd"],
            "--compare entry 2 (''): an entry is empty",
        ),
        (
            &["--compare", "rk4@fast"],
            "the step 'fast' is not a number of seconds: write it as 1/60, 1e-4 or dt=1e-4",
        ),
        (
            &["--compare", "rk4@0"],
            "the step 0 s must be a positive, finite number of seconds",
        ),
        (
            &["--compare", "semi-implicit,rk4@1/60"],
            "--compare entry 2 (rk4@1/60) is refused: dt = 1.667e-2 s is above the estimated stable step",
        ),
        (
            &["--compare", "rk4", "--integrator", "xpbd"],
            "--integrator and a comparison do not go together",
        ),
        (
            &["--compare", "rk4", "--dt", "auto"],
            "--dt auto and a comparison do not go together",
        ),
        (
            &["--compare", "euler@1e-4,semi-implicit@dt=x"],
            "--compare entry 2 ('semi-implicit@dt=x')",
        ),
    ];
    let dir = temp_dir("compare-bad");
    let path = dir.join("never.rrd");
    for (args, expected) in cases {
        let mut all = vec!["run", "cloth", "--backend", "cpu", "--save"];
        let p = path.to_string_lossy().into_owned();
        all.push(&p);
        all.extend_from_slice(args);
        let out = hooke(&all);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "{args:?} ran: {err}");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert_eq!(
            err.lines().filter(|l| l.starts_with("error")).count(),
            1,
            "{args:?}: one error: {err}"
        );
        assert!(!path.exists(), "{args:?} wrote a recording");
    }
    // Implicit Euler cannot simulate mass–mass contact: refused by name, with the reason.
    let out = hooke(&[
        "run",
        "pile",
        "--backend",
        "cpu",
        "--compare",
        "semi-implicit,implicit",
    ]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--compare entry 2 (implicit) is refused: implicit Euler does not support mass–mass contact"),
        "{err}"
    );
}

#[test]
fn a_realtime_comparison_never_runs_ahead_of_the_wall_clock() {
    // 12 frames at 60 Hz: at least 0.2 s, however fast the hair steps.
    let dir = temp_dir("compare-realtime");
    let path = dir.join("r.rrd");
    let start = std::time::Instant::now();
    let out = hooke(&[
        "run",
        "hair",
        "--backend",
        "cpu",
        "--frames",
        "12",
        "--realtime",
        "--compare",
        "semi-implicit,verlet",
        "--save",
        &path.to_string_lossy(),
    ]);
    let took = start.elapsed().as_secs_f64();
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(took >= 0.2, "12 frames in {took:.3} s");
    // Frame 1's time, with what a backend does once, is kept out of the plot (and frame 0
    // took no step).
    let rec = read_rrd(&path);
    assert_eq!(
        rec.frames_of("/compare/wall_ms/verlet"),
        (2..=12).collect::<Vec<i64>>()
    );
    assert_eq!(rec.frames_of("/compare/first_frame_wall_ms/verlet"), [1]);
}

#[test]
fn a_comparison_runs_on_the_gpu_backend_as_on_the_cpu() {
    if !common::gpu_available() {
        return;
    }
    let dir = temp_dir("compare-gpu");
    let path = dir.join("g.rrd");
    let out = hooke(&[
        "run",
        "hair",
        "--frames",
        "5",
        "--compare",
        "semi-implicit,verlet",
        "--save",
        &path.to_string_lossy(),
    ]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(
        read_rrd(&path).frames_of("/compare/gap_max/verlet"),
        [0, 1, 2, 3, 4, 5]
    );
}
