//! `hooke bench`: each benchmark run through the library, its figures printed.

use hooke::{accuracy, bench};

use super::args::BenchCommand;

pub fn bench(which: BenchCommand) -> anyhow::Result<()> {
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
        } => {
            let opts = accuracy::AccuracyOptions {
                device: device.device(),
                duration_secs: duration,
                points,
                coarsest,
                fast_end: !no_fast_end,
                repeat,
                out_dir: out.clone(),
                rrd: save.clone(),
            };
            let start = std::time::Instant::now();
            let report = accuracy::accuracy(&scene, &opts, &mut |done| {
                eprintln!("[{:>5.0} s] {done}", start.elapsed().as_secs_f64());
            })?;
            println!("{}", accuracy::markdown(&report));
            println!(
                "wrote {0}/accuracy-{1}.md, .csv and .svg (the work-precision chart){2}",
                out.display(),
                report.scene,
                save.map(|p| format!("; recording {}", p.display()))
                    .unwrap_or_default()
            );
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
    Ok(())
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
