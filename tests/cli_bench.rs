//! `hooke bench accuracy` and `--dt auto` end to end: the table, chart and stable-step search a
//! benchmark writes, and the step `--dt auto` picks for a tolerance.

use crate::common::{hooke, temp_dir, text};

/// `hooke bench accuracy hair` on the CPU over 0.1 s into `dir`, with `rest`: its stdout and CSV.
fn hair_accuracy(dir: &std::path::Path, rest: &[&str]) -> (String, String) {
    let dir = dir.to_string_lossy();
    let mut args = vec![
        "bench",
        "accuracy",
        "hair",
        "--backend",
        "cpu",
        "--duration",
        "0.1",
        "--out",
        &dir,
    ];
    args.extend_from_slice(rest);
    let out = hooke(&args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = std::fs::read_to_string(std::path::Path::new(&*dir).join("accuracy-hair.csv"))
        .unwrap_or_else(|e| panic!("{e}"));
    (text(&out.stdout), csv)
}

#[test]
fn bench_accuracy_writes_its_table_and_chart_and_finds_the_stable_step() {
    let dir = temp_dir("accuracy");
    let (stdout, csv) = hair_accuracy(&dir, &["--points", "3", "--coarsest", "0", "--no-fast-end"]);
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let integrators = hooke::integrator::Integrator::ALL.len();
    let (at_estimate, ladder): (Vec<_>, Vec<_>) = rows.iter().partition(|r| r[11] == "true");
    assert_eq!(
        ladder.len(),
        integrators * 3,
        "{integrators} integrators × three steps:\n{csv}"
    );
    // Each integrator with a finite estimate also runs at it (rounded down to whole substeps a
    // frame: 13, 1.282e-3 s), where the cheapest stable answers lie: on hair, semi-implicit
    // Euler's 1.368e-3 s is above the ladder's top, the scene's own 8.3e-4 s.
    let semi_limit = at_estimate
        .iter()
        .find(|r| r[1] == "semi-implicit")
        .unwrap_or_else(|| panic!("no semi-implicit row at its estimate:\n{csv}"));
    let dt: f64 = semi_limit[2].parse().unwrap_or(f64::NAN);
    assert!(
        (dt * 60.0 * 13.0 - 1.0).abs() < 1e-9 && semi_limit[7] == "true",
        "{csv}"
    );
    assert!(
        at_estimate
            .iter()
            .all(|r| !["euler", "rk2", "implicit", "bdf2"].contains(&r[1])),
        "a row at an estimate that is none or any:\n{csv}"
    );
    // XPBD's and VBD's estimates are the steps at which their sweeps still converge the
    // springs (1.06e-3 s and 3.6e-3 s on hair, above the ladder): each runs there, stably.
    for scheme in ["xpbd", "vbd"] {
        assert!(
            at_estimate.iter().any(|r| r[1] == scheme && r[7] == "true"),
            "{scheme} not run stably at its estimate:\n{csv}"
        );
    }
    // Semi-implicit Euler is first order: halving dt about halves the error.
    let semi: Vec<f64> = ladder
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
    // XPBD too is stable at every step, and the springs it projects lose energy: its error
    // falls with dt.
    let xpbd: Vec<&Vec<&str>> = ladder.iter().copied().filter(|r| r[1] == "xpbd").collect();
    assert!(
        xpbd.iter()
            .all(|r| r[7] == "true" && r[8].parse::<f64>().is_ok_and(|p| p > 0.0)),
        "{csv}"
    );
    let error = |r: &Vec<&str>| r[4].parse::<f64>().unwrap_or(f64::NAN);
    assert!(xpbd.windows(2).all(|w| error(w[1]) < error(w[0])), "{csv}");
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
    assert_guidance_names_the_cheapest_runs(&stdout, &rows, &csv);
    let svg =
        std::fs::read_to_string(dir.join("accuracy-hair.svg")).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        svg.starts_with("<svg") && svg.contains("polyline") && svg.trim_end().ends_with("</svg>")
    );
    assert!(dir.join("accuracy-hair.md").exists());
    let _ = std::fs::remove_dir_all(dir);
}

/// The fast end of the ladder: doublings of the scene's step up to one step per frame, where
/// the explicit schemes diverge and implicit Euler, BDF2 and VBD stay stable (XPBD with one sweep
/// stretches the strand there, its elastic energy growing: fast and wrong), and a table of each
/// solver there.
#[test]
fn bench_accuracy_reaches_one_step_per_frame() {
    let dir = temp_dir("accuracy-fast-end");
    let (stdout, csv) = hair_accuracy(&dir, &["--points", "2"]);
    let at_frame: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<&str>>())
        .filter(|r| (r[2].parse::<f64>().unwrap_or(0.0) * 60.0 - 1.0).abs() < 1e-9)
        .collect();
    assert_eq!(
        at_frame.len(),
        hooke::integrator::Integrator::ALL.len(),
        "a row per integrator at 1/60 s:
{csv}"
    );
    for r in &at_frame {
        match r[1] {
            "implicit" | "bdf2" | "vbd" => assert_eq!(r[7], "true", "{csv}"),
            "xpbd" => {}
            _ => assert_eq!(r[7], "false", "{csv}"),
        }
    }
    // Between the scene's step and the frame's, doublings: every step at most twice the next.
    let mut steps: Vec<f64> = csv
        .lines()
        .skip(1)
        .filter(|l| l.contains(",semi-implicit,"))
        .filter_map(|l| l.split(',').nth(2)?.parse().ok())
        .collect();
    steps.dedup();
    assert!(steps.len() >= 5, "{steps:?}");
    assert!(
        steps
            .windows(2)
            .all(|w| w[0] > w[1] && w[0] <= 2.0 * w[1] * 1.01),
        "{steps:?}"
    );
    assert!(stdout.contains("| 1e-1 m |"), "{stdout}");
    assert!(stdout.contains("At one step per frame"), "{stdout}");
    let _ = std::fs::remove_dir_all(dir);
}

/// `bench accuracy` is a sweep: through a real Slurm cluster its points end with the errors they
/// end with here, bit for bit, and each short point's time is the median of 3 runs.
#[test]
fn bench_accuracy_on_slurm_gives_the_errors_it_gives_here_timed_as_medians_of_three() {
    if !crate::sweep::slurm_here("bench_accuracy_on_slurm") {
        return;
    }
    let ladder = ["--points", "2", "--coarsest", "0", "--no-fast-end"];
    let here = temp_dir("accuracy-local");
    let (local_out, local) = hair_accuracy(&here, &ladder);
    let there = temp_dir("accuracy-slurm");
    let (slurm_out, slurm) = hair_accuracy(&there, &[&ladder[..], &["--on", "slurm"]].concat());
    // integrator, dt, steps, RMS and max error, energy drift, stable: all but time and backend.
    let physics = |csv: &str| -> Vec<String> {
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').take(9).collect::<Vec<_>>().join(","))
            .collect()
    };
    assert_eq!(
        physics(&local),
        physics(&slurm),
        "local:\n{local}\nslurm:\n{slurm}"
    );
    assert!(physics(&local).len() > 2 * hooke::integrator::Integrator::ALL.len());
    assert!(
        std::fs::read_to_string(there.join("accuracy-hair.sweep/slurm/array.sh"))
            .is_ok_and(|s| s.contains("#SBATCH --array=")),
        "not submitted as a job array"
    );
    for (out, dir) in [(&local_out, &here), (&slurm_out, &there)] {
        assert!(
            out.contains(
                "Wall time: the median of 3 timed runs of each point whose first took under 1 s"
            ),
            "{out}"
        );
        // Every point of 0.1 s of hair is short: three runs each, where it did not diverge.
        let sweep = dir.join("accuracy-hair.sweep");
        let results: Vec<_> = std::fs::read_dir(sweep.join("points"))
            .unwrap_or_else(|e| panic!("{e}"))
            .filter_map(|e| hooke::sweep::result::read(&e.ok()?.path().join("result.json")))
            .collect();
        assert!(
            results.len() == physics(&local).len(),
            "{}",
            sweep.display()
        );
        for r in results
            .iter()
            .filter(|r| r.status == hooke::sweep::result::Status::Ok)
        {
            assert_eq!(r.wall_secs_each.len(), 3, "{r:?}");
            let mut each = r.wall_secs_each.clone();
            each.sort_by(f64::total_cmp);
            assert_eq!(r.wall_secs, Some(each[1]), "{r:?}");
        }
        assert!(sweep.join("results.md").exists() && sweep.join("results.svg").exists());
    }
    let _ = std::fs::remove_dir_all(here);
    let _ = std::fs::remove_dir_all(there);
}

/// The guidance names, for each error level, the cheapest stable run that reached it and every
/// other within 10% of its cost (a tie: timing noise must not decide the answer), and no other.
fn assert_guidance_names_the_cheapest_runs(stdout: &str, rows: &[Vec<&str>], csv: &str) {
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
        let tied: Vec<(&str, f64)> = cells[2]
            .split(" = ")
            .zip(cells[3].split(" = "))
            .map(|(i, dt)| (i.split(" (").next().unwrap_or(i), num(dt)))
            .collect();
        let is =
            |r: &Vec<&str>, (i, dt): (&str, f64)| r[1] == i && (num(r[2]) / dt - 1.0).abs() < 1e-3;
        for &t in &tied {
            let row = reaching
                .iter()
                .find(|r| is(r, t))
                .unwrap_or_else(|| panic!("{line} names a run that does not reach it:\n{csv}"));
            assert!(
                num(row[9]) <= cheapest * 1.1,
                "{line}: not within 10% of the cheapest\n{csv}"
            );
        }
        for r in reaching.iter().filter(|r| num(r[9]) <= cheapest * 1.1) {
            assert!(
                tied.iter().any(|&t| is(r, t)),
                "{line} leaves out {} at {} ({} s), within 10% of the cheapest\n{csv}",
                r[1],
                r[2],
                r[9]
            );
        }
    }
    assert!(named >= 2, "{stdout}");
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
        text(&out.stderr).contains("expected seconds (like 0.001 or 1/60) or `auto`"),
        "{}",
        text(&out.stderr)
    );
}
