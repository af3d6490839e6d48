//! The Slurm executor: a job array with one task per point, written to `DIR/slurm/array.sh` and
//! submitted with `sbatch --parsable`; each task runs `hooke sweep point DIR $SLURM_ARRAY_TASK_ID`
//! with the absolute path of the binary that submitted it. The sweep then follows the job with
//! `squeue` (and `sacct`, where the cluster keeps accounting) until it ends. Nothing of the
//! scheduling is ours: Slurm's commands do it all, and their own words reach the user.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::error::{Error, Result};

use super::plan::{Layout, Plan};
use super::tally::Tally;

#[derive(Debug, Clone, Default)]
pub struct SlurmOptions {
    /// The `hooke` binary each task runs (absolute: nothing needs to be on the nodes' PATH).
    pub binary: PathBuf,
    pub partition: Option<String>,
    /// Each task's time limit, as Slurm writes it (`10:00`, `1-00:00:00`).
    pub time: Option<String>,
    pub gpus_per_task: Option<u32>,
    /// Tasks running at once (`%M` of `--array`).
    pub max_parallel: Option<u32>,
    /// Passed to `sbatch` as they are.
    pub sbatch_args: Vec<String>,
    /// How often `squeue` is asked while following.
    pub poll: Duration,
}

/// `0-3,5,7-9`: the indices as Slurm's `--array` writes a list.
pub fn array_list(indices: &[usize]) -> String {
    let mut sorted = indices.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let start = sorted[i];
        let mut end = start;
        while i + 1 < sorted.len() && sorted[i + 1] == end + 1 {
            i += 1;
            end = sorted[i];
        }
        parts.push(match end > start {
            true => format!("{start}-{end}"),
            false => start.to_string(),
        });
        i += 1;
    }
    parts.join(",")
}

/// A path as a single-quoted shell word.
fn quoted(p: &Path) -> String {
    format!("'{}'", p.to_string_lossy().replace('\'', r"'\''"))
}

/// The job script for `indices`.
pub fn script(layout: &Layout, plan: &Plan, indices: &[usize], opts: &SlurmOptions) -> String {
    let slurm = layout.slurm();
    let mut lines = vec![
        "#!/bin/bash".to_owned(),
        format!(
            "# Written by `hooke sweep`: one task per point of the sweep in {}.",
            layout.dir.display()
        ),
        "# Submitted with `sbatch --parsable` (submit it again by hand the same way).".to_owned(),
        format!("#SBATCH --job-name=hooke-sweep-{}", plan.id),
        format!(
            "#SBATCH --array={}{}",
            array_list(indices),
            opts.max_parallel
                .map(|m| format!("%{m}"))
                .unwrap_or_default()
        ),
        format!("#SBATCH --output={}/%A_%a.out", slurm.display()),
    ];
    if let Some(p) = &opts.partition {
        lines.push(format!("#SBATCH --partition={p}"));
    }
    if let Some(t) = &opts.time {
        lines.push(format!("#SBATCH --time={t}"));
    }
    if let Some(g) = opts.gpus_per_task {
        lines.push(format!("#SBATCH --gpus-per-task={g}"));
    }
    let load = match opts.max_parallel == Some(1) || indices.len() == 1 {
        true => "alone",
        false => "shared",
    };
    lines.push(format!(
        "exec {} sweep point {} \"$SLURM_ARRAY_TASK_ID\" --load {load}",
        quoted(&opts.binary),
        quoted(&layout.dir)
    ));
    lines.join("\n") + "\n"
}

/// Run a Slurm command: its standard output, or its own words when it refuses.
fn slurm_command(program: &str, args: &[String]) -> Result<String> {
    let out = Command::new(program).args(args).output().map_err(|e| {
        Error::Sweep(match e.kind() {
            std::io::ErrorKind::NotFound => format!(
                "`{program}` is not on PATH, so there is no Slurm cluster to submit to here: run on a machine of one (a login node), or use --on local (a one-node cluster for trying it: `bash .ci/slurm.sh`)"
            ),
            _ => format!("cannot run `{program}`: {e}"),
        })
    })?;
    if !out.status.success() {
        let said = String::from_utf8_lossy(&out.stderr).trim().to_owned();
        return Err(Error::Sweep(format!(
            "`{program} {}` failed ({}): {}",
            args.join(" "),
            out.status,
            if said.is_empty() {
                "it said nothing"
            } else {
                &said
            }
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Write the job script for `indices` and submit it: the job's id.
pub fn submit(dir: &Path, plan: &Plan, indices: &[usize], opts: &SlurmOptions) -> Result<String> {
    let layout = Layout::new(dir);
    let folder = layout.slurm();
    let io = |e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", folder.display()));
    std::fs::create_dir_all(&folder).map_err(io)?;
    let script_path = folder.join("array.sh");
    std::fs::write(&script_path, script(&layout, plan, indices, opts)).map_err(io)?;
    let mut args = vec!["--parsable".to_owned()];
    args.extend(opts.sbatch_args.iter().cloned());
    args.push(script_path.to_string_lossy().into_owned());
    let said = slurm_command("sbatch", &args)
        .map_err(|e| Error::Sweep(format!("Slurm refused the sweep's job: {e}")))?;
    // `--parsable` prints "ID" or "ID;CLUSTER".
    let id = said.trim().split(';').next().unwrap_or_default().to_owned();
    if id.is_empty() {
        return Err(Error::Sweep(format!(
            "sbatch accepted the job but printed no id (it said {said:?})"
        )));
    }
    let mut jobs = std::fs::read_to_string(folder.join("jobs")).unwrap_or_default();
    jobs.push_str(&format!("{id} {}\n", array_list(indices)));
    std::fs::write(folder.join("jobs"), jobs).map_err(io)?;
    Ok(id)
}

/// The sweep's jobs (`DIR/slurm/jobs`), oldest first.
fn jobs(layout: &Layout) -> Vec<String> {
    std::fs::read_to_string(layout.slurm().join("jobs"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .collect()
}

/// `squeue`'s state of each of the sweep's points still in Slurm's queue (empty where there is
/// no Slurm here, or no job of the sweep).
pub fn queued(layout: &Layout) -> HashMap<usize, String> {
    let jobs = jobs(layout);
    if jobs.is_empty() {
        return HashMap::new();
    }
    queued_in(&jobs.join(",")).unwrap_or_default()
}

/// The tasks of `jobs` in the queue; an error where `squeue` could not say (a job Slurm has
/// forgotten is not one: it has no task queued).
fn queued_in(jobs: &str) -> Result<HashMap<usize, String>> {
    let args: Vec<String> = ["-h", "-r", "-j", jobs, "-o", "%i %T"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let out = match slurm_command("squeue", &args) {
        Ok(out) => out,
        Err(Error::Sweep(m)) if m.contains("Invalid job id") => return Ok(HashMap::new()),
        Err(e) => return Err(e),
    };
    Ok(out
        .lines()
        .filter_map(|l| {
            let (id, state) = l.trim().split_once(' ')?;
            let (_, task) = id.split_once('_')?;
            Some((task.parse().ok()?, state.trim().to_owned()))
        })
        .collect())
}

/// What `sacct` says of each task of `job` (its state and exit code), where the cluster keeps
/// accounting; empty where it does not.
fn accounted(job: &str) -> HashMap<usize, String> {
    let args: Vec<String> = ["-n", "-P", "-X", "-j", job, "-o", "JobID,State,ExitCode"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let Ok(out) = slurm_command("sacct", &args) else {
        return HashMap::new();
    };
    out.lines()
        .filter_map(|l| {
            let mut f = l.split('|');
            let (id, state, code) = (f.next()?, f.next()?, f.next()?);
            let (_, task) = id.split_once('_')?;
            Some((task.parse().ok()?, format!("{state} (exit code {code})")))
        })
        .collect()
}

/// What a task that left no result said last: Slurm writes its own reason (`CANCELLED`, `DUE
/// TO TIME LIMIT`) into the task's output.
fn task_tail(layout: &Layout, job: &str, index: usize) -> String {
    let path = layout.slurm().join(format!("{job}_{index}.out"));
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    match text.lines().rev().find(|l| !l.trim().is_empty()) {
        Some(l) => format!("its output ({}) ends: {}", path.display(), l.trim()),
        None => format!("its output ({}) is empty", path.display()),
    }
}

/// Follow `job` until Slurm has no task of it left: how its points ended. `cancel` stops the
/// following, not the job.
pub fn follow(
    dir: &Path,
    plan: &Plan,
    job: &str,
    indices: &[usize],
    opts: &SlurmOptions,
    show_bar: bool,
    cancel: &AtomicBool,
) -> Result<Option<Tally>> {
    let layout = Layout::new(dir);
    let bar = super::tally::bar(indices.len() as u64, show_bar);
    let mut tally = Tally::default();
    let mut open: Vec<usize> = indices.to_vec();
    let mut squeue_failures = 0;
    loop {
        if cancel.load(Ordering::SeqCst) {
            bar.abandon();
            return Ok(None);
        }
        let queue = match queued_in(job) {
            Ok(q) => q,
            // A controller busy for a moment; a lasting failure is the user's to see.
            Err(e) if squeue_failures < 30 => {
                squeue_failures += 1;
                let _ = e;
                std::thread::sleep(opts.poll);
                continue;
            }
            Err(e) => return Err(e),
        };
        squeue_failures = 0;
        let ended = queue.is_empty();
        // A task whose result is there, or that Slurm no longer holds, has ended.
        let accounting = if ended {
            accounted(job)
        } else {
            HashMap::new()
        };
        let mut k = 0;
        while k < open.len() {
            let i = open[k];
            let has_result = layout.result(i).exists();
            if has_result || (ended && !queue.contains_key(&i)) {
                open.swap_remove(k);
                let line = tally.add(&layout, plan, i, || {
                    let slurm_said = accounting
                        .get(&i)
                        .map(|s| format!("Slurm says {s}; "))
                        .unwrap_or_default();
                    format!("{slurm_said}{}", task_tail(&layout, job, i))
                });
                super::tally::say(&bar, show_bar, line);
                bar.inc(1);
                bar.set_message(tally.brief());
            } else {
                k += 1;
            }
        }
        if ended && open.is_empty() {
            break;
        }
        let running = queue.values().filter(|s| s.as_str() == "RUNNING").count();
        bar.set_message(format!("{}; {running} running in Slurm", tally.brief()));
        std::thread::sleep(opts.poll);
    }
    bar.finish_with_message(tally.brief());
    Ok(Some(tally))
}
