//! `hooke bench`: each benchmark run through the library, its figures printed.

use hooke::bench::accuracy::AccuracyOptions;
use hooke::{accuracy, bench};

use super::args::BenchCommand;
use super::outcome::Outcome;
use super::sweep::{Afterwards, ExecArgs, execute, on_interrupt};

pub fn bench(which: BenchCommand) -> anyhow::Result<Outcome> {
    match which {
        BenchCommand::Soak {
            scene,
            device,
            duration,
            save,
            no_rrd_footer,
        } => {
            let s = bench::soak(&scene, &device.device(), duration, &save, !no_rrd_footer)?;
            println!("{}", bench::format_soak(&s));
        }
        BenchCommand::Accuracy {
            scene,
            device,
            duration,
            points,
            coarsest,
            no_fast_end,
            repeat,
            out,
            save,
            exec,
        } => {
            let opts = AccuracyOptions {
                device: device.device(),
                duration_secs: duration,
                ladder: accuracy::LadderOptions {
                    points,
                    coarsest,
                    fast_end: !no_fast_end,
                },
                repeat,
                out_dir: out.clone(),
                rrd: save.clone(),
            };
            return bench_accuracy(&scene, &opts, &exec);
        }
        BenchCommand::Stability {
            scenes,
            device,
            duration,
            integrators,
            out,
        } => {
            let integrators = if integrators.is_empty() {
                hooke::integrator::Integrator::ALL.to_vec()
            } else {
                integrators
            };
            let scenes = if scenes.is_empty() {
                hooke::scene::BUILT_IN
                    .iter()
                    .map(|b| b.name.to_owned())
                    .filter(|n| n != "cloth-1024")
                    .collect()
            } else {
                scenes
            };
            let device = device.device();
            let start = std::time::Instant::now();
            let (rows, device_name) =
                accuracy::measure_limits(&scenes, &integrators, &device, duration, &mut |r| {
                    eprintln!(
                        "[{:>5.0} s] {} {}: estimate {:?}, measured {:?}",
                        start.elapsed().as_secs_f64(),
                        r.scene,
                        r.integrator,
                        r.estimate_secs,
                        r.measured
                    );
                })?;
            let table = accuracy::limits_markdown(&rows, duration, &device_name);
            println!("{table}");
            if let Some(path) = out {
                std::fs::write(&path, &table)
                    .map_err(|e| anyhow::anyhow!("could not write {}: {e}", path.display()))?;
                println!("wrote {}", path.display());
            }
            let over = rows.iter().filter(|r| !r.holds()).count();
            if over > 0 {
                anyhow::bail!("{over} estimate(s) overshoot the measured stable step");
            }
        }
        BenchCommand::Record {
            scene,
            frames,
            save,
            recording,
        } => {
            let opts = bench::RecordBenchOptions {
                frames,
                record: recording.options(),
                save,
            };
            println!("{}", bench::format_record(&bench::record(&scene, &opts)?));
        }
        BenchCommand::Throughput {
            scenes,
            device,
            integrator,
            steps,
            batch,
            effects,
            repeat,
            json,
            preconditioner,
        } => {
            let opts = bench::ThroughputOptions {
                device: device.device(),
                integrator,
                steps,
                batch,
                repeat,
                preconditioner,
            };
            throughput(scenes, &opts, Shown { effects, json })?;
        }
    }
    Ok(Outcome::Done)
}

/// `bench accuracy`: its ladder planned as a sweep, the reference computed, the points run where
/// `exec` says, then the stable steps searched and the tables written.
fn bench_accuracy(scene: &str, opts: &AccuracyOptions, exec: &ExecArgs) -> anyhow::Result<Outcome> {
    if exec.detach {
        anyhow::bail!(
            "bench accuracy waits for its points to write its tables: leave out --detach (`hooke sweep run --detach` submits a sweep and returns)"
        );
    }
    let start = std::time::Instant::now();
    let mut say = |done: &str| eprintln!("[{:>5.0} s] {done}", start.elapsed().as_secs_f64());
    let sweep = bench::accuracy::plan(scene, opts)?;
    let cancel = on_interrupt();
    say(&format!(
        "reference: f64 RK4 at dt = {:.3e} s",
        sweep.reference_dt_secs()
    ));
    if !bench::accuracy::reference(&sweep, &cancel)? {
        eprintln!("bench accuracy: interrupted while computing its reference");
        return Ok(Outcome::Interrupted);
    }
    say(&format!(
        "{} points (integrator × step) in {}",
        sweep.plan.points.len(),
        sweep.dir.display()
    ));
    let all: Vec<usize> = (0..sweep.plan.points.len()).collect();
    if let Outcome::Interrupted = execute(
        &sweep.dir,
        &sweep.plan,
        &all,
        exec,
        &cancel,
        Afterwards::Quiet,
    )? {
        eprintln!("bench accuracy: interrupted before its tables; run it again to measure afresh");
        return Ok(Outcome::Interrupted);
    }
    let report = bench::accuracy::finish(&sweep, opts, &mut say)?;
    println!("{}", accuracy::markdown(&report));
    println!(
        "wrote {0}/accuracy-{1}.md, .csv and .svg (the work-precision chart){2}; each point's result in {3}",
        opts.out_dir.display(),
        report.scene,
        opts.rrd
            .as_ref()
            .map(|p| format!("; recording {}", p.display()))
            .unwrap_or_default(),
        sweep.dir.display()
    );
    Ok(Outcome::Done)
}

/// What `bench throughput` prints besides its table.
struct Shown {
    /// The effects each scene compiles in.
    effects: bool,
    /// JSON instead of text.
    json: bool,
}

fn throughput(
    scenes: Vec<String>,
    opts: &bench::ThroughputOptions,
    Shown { effects, json }: Shown,
) -> anyhow::Result<()> {
    let scenes = if scenes.is_empty() {
        vec!["cloth-64".to_owned(), "cloth-256".to_owned()]
    } else {
        scenes
    };
    for s in &scenes {
        if effects {
            println!(
                "{}",
                bench::format_effect_costs(&bench::effect_costs(s, opts)?)
            );
        } else if json {
            println!("{}", bench::throughput_json(&bench::throughput(s, opts)?));
        } else {
            println!("{}", bench::format_throughput(&bench::throughput(s, opts)?));
        }
    }
    Ok(())
}
