//! The local executor: each point a child process (`hooke sweep point DIR N`, the very command a
//! Slurm task runs), CPU points sharing the cores and GPU points taking the adapter a few at a
//! time, with a bar of points done, failed and left. A child that dies leaves no result, and
//! nothing else is disturbed.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::error::{Error, Result};

use super::plan::{Layout, Plan};
use super::result::Load;
use super::tally::Tally;

#[derive(Debug, Clone)]
pub struct LocalOptions {
    /// The `hooke` binary the points run with.
    pub binary: PathBuf,
    /// CPU points at once.
    pub jobs: usize,
    /// GPU points at once (they share one adapter).
    pub gpu_jobs: usize,
    /// Draw a progress bar (on a terminal); a line per point is printed either way.
    pub bar: bool,
}

struct Running {
    index: usize,
    gpu: bool,
    child: Child,
}

/// Run `indices` of the sweep in `dir`: how they ended.
pub fn run_local(
    dir: &Path,
    plan: &Plan,
    indices: &[usize],
    opts: &LocalOptions,
    cancel: &AtomicBool,
) -> Result<Tally> {
    let layout = Layout::new(dir);
    let (jobs, gpu_jobs) = (opts.jobs.max(1), opts.gpu_jobs.max(1));
    let gpu = |i: usize| plan.points[i].backend == "gpu";
    let cpu_points = indices.iter().filter(|&&i| !gpu(i)).count();
    let at_once = jobs.min(cpu_points) + gpu_jobs.min(indices.len() - cpu_points);
    let load = if at_once > 1 {
        Load::Shared
    } else {
        Load::Alone
    };
    let bar = super::tally::bar(indices.len() as u64, opts.bar);
    let mut left: std::collections::VecDeque<usize> = indices.iter().copied().collect();
    let mut running: Vec<Running> = Vec::new();
    let mut tally = Tally::default();
    while !left.is_empty() || !running.is_empty() {
        if cancel.load(Ordering::SeqCst) {
            for r in &mut running {
                let _ = r.child.kill();
                let _ = r.child.wait();
            }
            bar.abandon_with_message("interrupted: `hooke sweep resume DIR` runs the points left");
            return Ok(tally);
        }
        // Start what the free slots allow, in order, skipping a kind whose slots are full.
        let mut k = 0;
        while k < left.len() {
            let i = left[k];
            let slots = if gpu(i) { gpu_jobs } else { jobs };
            let busy = running.iter().filter(|r| r.gpu == gpu(i)).count();
            if busy < slots {
                left.remove(k);
                running.push(Running {
                    index: i,
                    gpu: gpu(i),
                    child: spawn(&opts.binary, &layout, i, load)?,
                });
            } else {
                k += 1;
            }
        }
        let mut n = 0;
        while n < running.len() {
            let exited = running[n]
                .child
                .try_wait()
                .map_err(|e| Error::Sweep(format!("cannot watch a point's process: {e}")))?;
            match exited {
                Some(status) => {
                    let r = running.swap_remove(n);
                    let line = tally.add(&layout, plan, r.index, || {
                        format!(
                            "its process ended with {status}; {}",
                            log_tail(&layout, r.index)
                        )
                    });
                    super::tally::say(&bar, opts.bar, line);
                    bar.inc(1);
                    bar.set_message(tally.brief());
                }
                None => n += 1,
            }
        }
        // Short: a point of milliseconds (bench accuracy on hair) must not wait for the next look.
        std::thread::sleep(Duration::from_millis(5));
    }
    bar.finish_with_message(tally.brief());
    Ok(tally)
}

fn spawn(binary: &Path, layout: &Layout, index: usize, load: Load) -> Result<Child> {
    let folder = layout.point(index);
    let io = |what: &str, e: std::io::Error| Error::Sweep(format!("point {index}: {what}: {e}"));
    std::fs::create_dir_all(&folder).map_err(|e| io("cannot make its folder", e))?;
    let log = std::fs::File::create(folder.join("log.txt"))
        .map_err(|e| io("cannot write its log.txt", e))?;
    let err = log
        .try_clone()
        .map_err(|e| io("cannot write its log.txt", e))?;
    Command::new(binary)
        .arg("sweep")
        .arg("point")
        .arg(&layout.dir)
        .arg(index.to_string())
        .arg("--load")
        .arg(match load {
            Load::Alone => "alone",
            Load::Shared => "shared",
        })
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(err)
        .spawn()
        .map_err(|e| io(&format!("cannot start {}", binary.display()), e))
}

/// The last line a point's process wrote, for a point that ended without a result.
fn log_tail(layout: &Layout, index: usize) -> String {
    let text = std::fs::read_to_string(layout.point(index).join("log.txt")).unwrap_or_default();
    match text.lines().rev().find(|l| !l.trim().is_empty()) {
        Some(l) => format!("its log ends: {}", l.trim()),
        None => "its log is empty".to_owned(),
    }
}
