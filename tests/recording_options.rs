//! What a run's recording options give, read back from the .rrd: `--springs` (none, structural,
//! each body's default by size), `--masses`, `--realtime`, a bad option's one clear error, and the
//! default layout's plots (a legend in a corner of each time series, a colour of its own for
//! every series) and its 3D view's eye on the bodies. What a
//! surface and its springs hold is in tests/recording.rs.

use hooke::integrator::Step;
use std::collections::BTreeSet;

use crate::common::record::{at_frame, read_components, record, stepped};
use crate::common::{hooke, save_cpu_run, temp_dir};
use hooke::record::{MORE_SERIES, Plot, RecordOptions, SERIES, SpringSelection};
use hooke::state::Snapshot;
use rerun::external::arrow::array::{Array as _, ArrayRef, BooleanArray, StringArray, UInt32Array};

/// Entities of a recording made by `hooke run` with `args`.
fn run_entities(name: &str, args: &[&str]) -> BTreeSet<String> {
    let dir = temp_dir(name);
    let path = dir.join("run.rrd");
    let path_s = path.to_string_lossy().into_owned();
    let mut all = vec!["run"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--backend", "cpu", "--save", &path_s]);
    let out = hooke(&all);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let entities = read_components(&path).into_keys().map(|(e, _)| e).collect();
    let _ = std::fs::remove_dir_all(dir);
    entities
}

#[test]
fn springs_none_logs_no_lines_and_structural_only_the_structural_springs() {
    for scene in ["hair", "cloth", "jello"] {
        let e = run_entities(scene, &[scene, "--frames", "3", "--springs", "none"]);
        let lines: Vec<&String> = e.iter().filter(|p| p.ends_with("/springs")).collect();
        assert!(lines.is_empty(), "{scene}: {lines:?}");
    }
    // Structural: exactly the structural springs, as hover kinds say.
    let (loaded, model, snaps) = stepped("cloth", 1);
    let dir = temp_dir("structural");
    let path = dir.join("cloth.rrd");
    let opts = RecordOptions {
        springs: Some(SpringSelection::Structural),
        ..RecordOptions::default()
    };
    record(&loaded, &model, &snaps, opts, &path);
    let c = read_components(&path);
    let kinds = at_frame(&c, "/world/cloth/springs", "kind", 0);
    let kinds = kinds
        .as_any()
        .downcast_ref::<StringArray>()
        .unwrap_or_else(|| panic!("kind is not text"));
    let structural = model
        .spring_kind
        .iter()
        .filter(|k| **k == hooke::model::SpringKindTag::Structural)
        .count();
    assert_eq!(kinds.len(), structural);
    assert!((0..kinds.len()).all(|i| kinds.value(i) == "structural"));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_large_sheet_leaves_its_springs_out_by_default_and_masses_are_on_demand() {
    let default = run_entities("large", &["cloth-64", "--frames", "1"]);
    assert!(default.contains("/world/cloth/surface"));
    assert!(default.contains("/world/cloth/pins"));
    assert!(!default.contains("/world/cloth/springs"), "{default:?}");
    assert!(!default.contains("/world/cloth/masses"), "{default:?}");
    let asked = run_entities(
        "large-asked",
        &["cloth-64", "--frames", "1", "--springs", "all", "--masses"],
    );
    assert!(asked.contains("/world/cloth/springs"));
    assert!(asked.contains("/world/cloth/masses"));
}

#[test]
fn realtime_never_delivers_a_frame_before_its_time() {
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned("hair").unwrap_or_else(|e| panic!("{e}"));
    let be = Box::new(hooke::cpu::CpuBackend::new(
        model,
        Step::new(settings.integrator, settings.dt_secs),
    ));
    let pacer = hooke::run::pacing::Pacer::start(settings.frame_rate_hz);
    let mut paced = hooke::run::pacing::paced(be, pacer);
    let (tx, rx) = crossbeam_channel::bounded(64);
    let frames = 12;
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let received = std::thread::scope(|s| {
        let receiver = s.spawn(|| {
            rx.iter()
                .map(|snap: Snapshot| (snap.frame, pacer.started().elapsed()))
                .collect::<Vec<_>>()
        });
        let out = hooke::run::sim::simulate(
            paced.as_mut(),
            frames,
            settings.substeps,
            &tx,
            hooke::run::sim::Delivery::Lossless,
            &cancel,
            None,
        );
        drop(tx);
        assert_eq!(out.frames_sent, frames + 1);
        receiver
            .join()
            .unwrap_or_else(|_| panic!("receiver panicked"))
    });
    assert_eq!(received.len(), frames as usize + 1);
    for (frame, at) in received {
        let due = pacer.due(frame);
        assert!(
            at >= due,
            "frame {frame} delivered at {at:?}, due at {due:?}"
        );
    }
}

#[test]
fn realtime_from_the_command_line_takes_at_least_the_simulated_time() {
    let dir = temp_dir("realtime");
    let path = dir.join("hair.rrd");
    let start = std::time::Instant::now();
    // 30 frames at 60 Hz: half a second of simulated time.
    save_cpu_run("hair", 30, &path, &["--realtime"]);
    assert!(start.elapsed() >= std::time::Duration::from_millis(500));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_recording_options_are_one_clear_error() {
    let out = hooke(&["run", "cloth", "--springs", "some"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--springs") && err.contains("all") && err.contains("structural"),
        "{err}"
    );
    let out = hooke(&["bench", "record", "cloth", "--frames", "0"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("--frames") && err.contains('0'), "{err}");
    let out = hooke(&["run", "cloth", "--masses=yes"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--masses"), "{err}");
}

#[test]
fn every_time_series_names_its_lines_and_the_eye_is_on_the_bodies() {
    let dir = temp_dir("legends");
    let path = dir.join("run.rrd");
    save_cpu_run("cloth", 2, &path, &["--integrator", "implicit"]);
    let c = read_components(&path);
    let strings = |a: &ArrayRef| -> Vec<String> {
        let a = a
            .as_any()
            .downcast_ref::<StringArray>()
            .unwrap_or_else(|| panic!("not strings: {a:?}"));
        (0..a.len()).map(|i| a.value(i).to_owned()).collect()
    };
    let views = |class: &str| -> Vec<&String> {
        c.iter()
            .filter(|((_, comp), _)| comp.ends_with("class_identifier"))
            .filter(|(_, rows)| {
                rows.iter()
                    .any(|(_, a)| strings(a).iter().any(|s| s == class))
            })
            .map(|((e, _), _)| e)
            .collect()
    };
    // The layout is sent as the run starts and again, its eye framed on the whole run, when
    // it ends: each time four time series, one histogram, one 3D view.
    let (series, bars) = (views("TimeSeries"), views("BarChart"));
    assert_eq!((series.len(), bars.len()), (8, 2), "{series:?} {bars:?}");
    // Each time series names its lines in a legend; the histogram's one series needs none.
    let legend_shown = |view: &String| {
        let legend = format!("{view}/PlotLegend");
        let rows = c
            .iter()
            .find(|((e, comp), _)| *e == legend && comp.ends_with("visible"))
            .map(|(_, rows)| rows)
            .unwrap_or_else(|| panic!("{legend} has no visibility"));
        let (_, a) = &rows[0];
        a.as_any()
            .downcast_ref::<BooleanArray>()
            .unwrap_or_else(|| panic!("not a bool: {a:?}"))
            .value(0)
    };
    assert!(
        series.iter().all(|v| legend_shown(v)),
        "a time series without its legend"
    );
    assert!(
        bars.iter().all(|v| !legend_shown(v)),
        "the histogram shows a legend"
    );
    // Both eyes look at a point among the bodies (the cloth hangs from 1.2 m and drapes over
    // the sphere), from in front of it and above.
    let spatial = views("3D");
    assert_eq!(spatial.len(), 2, "{spatial:?}");
    for view in spatial {
        let at = |field: &str| -> glam::Vec3 {
            let path = format!("{view}/EyeControls3D");
            let (_, a) = c
                .iter()
                .find(|((e, comp), _)| *e == path && comp.ends_with(field))
                .and_then(|(_, rows)| rows.first())
                .unwrap_or_else(|| panic!("{path} has no {field}"));
            let list = a
                .as_any()
                .downcast_ref::<rerun::external::arrow::array::FixedSizeListArray>()
                .unwrap_or_else(|| panic!("{field} not a fixed list: {a:?}"));
            let v = list.value(0);
            let f = v
                .as_any()
                .downcast_ref::<rerun::external::arrow::array::Float32Array>()
                .unwrap_or_else(|| panic!("{field} not f32: {v:?}"));
            glam::Vec3::new(f.value(0), f.value(1), f.value(2))
        };
        let (target, eye) = (at("look_target"), at("position"));
        let inside = glam::Vec3::new(-0.8, 0.0, -0.2).cmple(target).all()
            && target.cmple(glam::Vec3::new(0.8, 1.3, 1.6)).all();
        assert!(inside, "the eye looks at {target}");
        let from = eye - target;
        assert!(
            from.z > 0.0 && from.y > 0.0,
            "the eye at {eye} looks at {target}"
        );
    }
    // Within each plot, the series the run logs have distinct colours, so that they read
    // without a legend; the legend document names them.
    for plot in [Plot::Energy, Plot::Strain, Plot::Millis, Plot::Count] {
        let mut colours = BTreeSet::new();
        for s in SERIES.iter().chain(&MORE_SERIES).filter(|s| s.plot == plot) {
            let Some((_, rows)) = c.iter().find(|((e, comp), _)| {
                e.trim_start_matches('/') == s.path && comp.ends_with("colors")
            }) else {
                continue;
            };
            let a = rows[0]
                .1
                .as_any()
                .downcast_ref::<UInt32Array>()
                .unwrap_or_else(|| panic!("{}: colours not u32", s.path));
            assert!(colours.insert(a.value(0)), "{} shares a colour", s.path);
        }
        assert!(!colours.is_empty(), "{plot:?} has no series");
    }
    let legend = c
        .iter()
        .find(|((e, comp), _)| e == "/legend" && comp.ends_with("text"))
        .map(|(_, rows)| strings(&rows[0].1).concat())
        .unwrap_or_default();
    for s in [
        "CG iterations **cyan**",
        "kinetic **orange**",
        "stepping **blue**",
    ] {
        assert!(legend.contains(s), "legend lacks {s:?}: {legend}");
    }
    let _ = std::fs::remove_dir_all(dir);
}
