//! `hooke sweep plan | run | point | status | resume | report`: the command line of
//! [`hooke::sweep`].

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Subcommand;

use hooke::sweep::local::LocalOptions;
use hooke::sweep::result::Load;
use hooke::sweep::slurm::SlurmOptions;
use hooke::sweep::status::PointState;
use hooke::sweep::tally::Tally;
use hooke::sweep::{self, Plan};

use super::outcome::Outcome;

#[derive(Debug, Subcommand)]
pub enum SweepCommand {
    /// List a sweep file's points and what they will cost, without running them.
    Plan {
        /// The sweep file (TOML; examples/sweeps/ has some).
        file: PathBuf,
    },
    /// Run a sweep file's points into a new folder.
    Run {
        /// The sweep file (TOML; examples/sweeps/ has some).
        file: PathBuf,
        /// The sweep's folder (made; it must not hold another sweep). On Slurm, on storage
        /// that the nodes share.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// Run the points of a sweep's folder that have no result (or a failed one).
    Resume {
        /// The sweep's folder (`run`'s --out).
        dir: PathBuf,
        #[command(flatten)]
        exec: ExecArgs,
    },
    /// Say which points are done (and how), running or missing.
    Status {
        /// The sweep's folder (`run`'s --out).
        dir: PathBuf,
    },
    /// Write results.csv, results.md and results.svg from the points' results.
    Report {
        /// The sweep's folder (`run`'s --out).
        dir: PathBuf,
        /// Where the files go (the sweep's folder by default).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run one point (what each executor's task runs; rarely typed by hand).
    Point {
        /// The sweep's folder.
        dir: PathBuf,
        /// The point's number (from 0, as `plan` lists them).
        index: usize,
        /// Whether other points run beside this one (its time is then marked as not clean).
        #[arg(long, value_enum, default_value = "alone")]
        load: Load,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Executor {
    /// This machine: points in parallel, as child processes.
    Local,
    /// A Slurm job array, one task per point, submitted with sbatch.
    Slurm,
}

#[derive(Debug, Clone, clap::Args)]
pub struct ExecArgs {
    /// Where the points run.
    #[arg(long, value_enum, default_value = "local")]
    pub on: Executor,
    /// Local: CPU points at once (default: one per core; one for a sweep that times, whose
    /// times are then clean).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Local: GPU points at once (they share the adapter).
    #[arg(long, default_value_t = 1)]
    pub gpu_jobs: usize,
    /// Slurm: the partition.
    #[arg(long)]
    pub partition: Option<String>,
    /// Slurm: each task's time limit (`10:00`, `1-00:00:00`).
    #[arg(long)]
    pub time: Option<String>,
    /// Slurm: GPUs for each task.
    #[arg(long)]
    pub gpus_per_task: Option<u32>,
    /// Slurm: tasks running at once.
    #[arg(long)]
    pub max_parallel: Option<u32>,
    /// Slurm: an argument for sbatch, as it is (repeat for more).
    #[arg(long = "sbatch-arg", allow_hyphen_values = true)]
    pub sbatch_args: Vec<String>,
    /// Slurm: return once the job is submitted (`hooke sweep status DIR` follows it).
    #[arg(long)]
    pub detach: bool,
}

pub fn sweep(which: SweepCommand) -> anyhow::Result<Outcome> {
    match which {
        SweepCommand::Plan { file } => {
            let plan = sweep::plan::from_file(&file)?;
            print!("{}", sweep::cost::describe(&plan)?);
            Ok(Outcome::Done)
        }
        SweepCommand::Run { file, out, exec } => {
            let plan = sweep::plan::from_file(&file)?;
            sweep::plan::start(&plan, &out)?;
            eprintln!(
                "sweep: {} points of '{}' in {}",
                plan.points.len(),
                plan.scene,
                out.display()
            );
            let all: Vec<usize> = (0..plan.points.len()).collect();
            execute(
                &out,
                &plan,
                &all,
                &exec,
                &on_interrupt(),
                Afterwards::SayHowToSeeResults,
            )
        }
        SweepCommand::Resume { dir, exec } => {
            let plan = sweep::plan::read(&dir)?;
            let states = sweep::status::states(&dir, &plan);
            let left = sweep::status::to_run(&states);
            if left.is_empty() {
                eprintln!(
                    "sweep: every point of {} has a result or is running; nothing to resume",
                    dir.display()
                );
                return Ok(Outcome::Done);
            }
            eprintln!(
                "sweep: resuming {} of {} points in {}",
                left.len(),
                plan.points.len(),
                dir.display()
            );
            execute(
                &dir,
                &plan,
                &left,
                &exec,
                &on_interrupt(),
                Afterwards::SayHowToSeeResults,
            )
        }
        SweepCommand::Status { dir } => {
            let plan = sweep::plan::read(&dir)?;
            print!(
                "{}",
                status_text(&plan, &sweep::status::states(&dir, &plan))
            );
            Ok(Outcome::Done)
        }
        SweepCommand::Report { dir, out } => {
            let plan = sweep::plan::read(&dir)?;
            for p in sweep::report::write(&dir, &plan, out.as_deref().unwrap_or(&dir))? {
                println!("wrote {}", p.display());
            }
            Ok(Outcome::Done)
        }
        SweepCommand::Point { dir, index, load } => {
            let cancel = on_interrupt();
            match sweep::point::run_point(&dir, index, load, &cancel)? {
                Some(r) => {
                    eprintln!(
                        "point {index} ({}): {}{}",
                        r.label,
                        r.status,
                        r.message.map(|m| format!(": {m}")).unwrap_or_default()
                    );
                    Ok(Outcome::Done)
                }
                None => {
                    eprintln!(
                        "point {index}: interrupted; it has no result, and a resume runs it again"
                    );
                    Ok(Outcome::Interrupted)
                }
            }
        }
    }
}

/// Ctrl-C and SIGTERM (Slurm's `scancel`) set the flag (once a process: a second handler is
/// refused).
pub fn on_interrupt() -> Arc<AtomicBool> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
        eprintln!("warning: cannot catch Ctrl-C ({e}); an interrupt ends the sweep at once");
    }
    cancel
}

/// What a finished sweep says last.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Afterwards {
    /// How to see its results: `sweep report`, `rerun server -d`.
    SayHowToSeeResults,
    /// Nothing: the caller shows the results itself (`bench accuracy`).
    Quiet,
}

/// Run `indices` of the sweep in `dir` where `exec` says, until they end or `cancel` is set,
/// ending as `afterwards` says.
pub fn execute(
    dir: &Path,
    plan: &Plan,
    indices: &[usize],
    exec: &ExecArgs,
    cancel: &Arc<AtomicBool>,
    afterwards: Afterwards,
) -> anyhow::Result<Outcome> {
    let binary = std::env::current_exe()
        .and_then(|p| p.canonicalize())
        .map_err(|e| anyhow::anyhow!("cannot find this hooke binary's own path: {e}"))?;
    let bar = std::io::stderr().is_terminal();
    let tally = match exec.on {
        Executor::Local => {
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            let opts = LocalOptions {
                binary,
                jobs: exec.jobs.unwrap_or(if plan.timed { 1 } else { cores }),
                gpu_jobs: exec.gpu_jobs,
                bar,
            };
            sweep::local::run_local(dir, plan, indices, &opts, cancel)?
        }
        Executor::Slurm => {
            let opts = SlurmOptions {
                binary,
                partition: exec.partition.clone(),
                time: exec.time.clone(),
                gpus_per_task: exec.gpus_per_task,
                max_parallel: exec.max_parallel,
                sbatch_args: exec.sbatch_args.clone(),
                poll: std::time::Duration::from_millis(500),
            };
            let job = sweep::slurm::submit(dir, plan, indices, &opts)?;
            eprintln!(
                "sweep: submitted Slurm job {job} ({} tasks; script {})",
                indices.len(),
                sweep::Layout::new(dir).slurm().join("array.sh").display()
            );
            if exec.detach {
                eprintln!(
                    "sweep: not following it (--detach): `hooke sweep status {}` says where it stands",
                    dir.display()
                );
                return Ok(Outcome::Done);
            }
            match sweep::slurm::follow(dir, plan, &job, indices, &opts, bar, cancel)? {
                Some(t) => t,
                None => {
                    eprintln!(
                        "sweep: stopped following; job {job} goes on in Slurm (`scancel {job}` stops it, `hooke sweep status {}` follows it)",
                        dir.display()
                    );
                    return Ok(Outcome::Interrupted);
                }
            }
        }
    };
    finish(dir, plan, &tally, cancel, afterwards)
}

fn finish(
    dir: &Path,
    plan: &Plan,
    tally: &Tally,
    cancel: &AtomicBool,
    afterwards: Afterwards,
) -> anyhow::Result<Outcome> {
    if cancel.load(Ordering::SeqCst) {
        eprintln!(
            "sweep: interrupted ({}); `hooke sweep resume {}` runs the points left",
            tally.brief(),
            dir.display()
        );
        return Ok(Outcome::Interrupted);
    }
    eprintln!("sweep: {}", tally.brief());
    if tally.unfinished() > 0 {
        anyhow::bail!(
            "{} point(s) of the sweep in {} have no usable result (their lines above say why): `hooke sweep resume {}` runs them again",
            tally.unfinished(),
            dir.display(),
            dir.display()
        );
    }
    match plan.record {
        _ if afterwards == Afterwards::Quiet => {}
        true => eprintln!(
            "sweep: `hooke sweep report {}` writes the tables and chart; `rerun server -d {}` serves the recordings as one dataset",
            dir.display(),
            sweep::Layout::new(dir).points().display()
        ),
        false => eprintln!(
            "sweep: `hooke sweep report {}` writes the tables and chart",
            dir.display()
        ),
    }
    Ok(Outcome::Done)
}

fn status_text(plan: &Plan, states: &[PointState]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    for (i, s) in states.iter().enumerate() {
        let word = match s {
            PointState::Done(status) => status.to_string(),
            PointState::InSlurm(state) => format!("in Slurm: {}", state.to_lowercase()),
            PointState::Running => "running here".to_owned(),
            PointState::Missing => "missing".to_owned(),
        };
        let _ = writeln!(out, "{i:>5}  {:<20} {}", word, plan.points[i].label());
        *counts.entry(word).or_default() += 1;
    }
    let summary: Vec<String> = counts.iter().map(|(w, n)| format!("{n} {w}")).collect();
    let _ = writeln!(out, "{} points: {}", states.len(), summary.join(", "));
    out
}
