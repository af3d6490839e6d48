//! How far a run is: a bar on a terminal, a short line every few seconds in a log.
//!
//! Both say the frames recorded, the simulated time and the real-time factor (simulated seconds
//! per wall second: above 1, the run is faster than real time).

use std::time::{Duration, Instant};

/// Where progress goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgressMode {
    /// A bar redrawn in place (stderr is a terminal).
    Bar,
    /// One line every `every` of wall time (stderr is a file or a pipe: a script, a server's log).
    Lines { every: Duration },
    /// Nothing (library callers, benchmarks).
    Off,
}

impl ProgressMode {
    /// Lines in a log: often enough to follow a long run, rare enough not to flood the log.
    pub const LOG_INTERVAL: Duration = Duration::from_secs(5);

    /// The mode for stderr: a bar on a terminal, lines otherwise.
    pub fn for_stderr(is_terminal: bool) -> Self {
        if is_terminal {
            ProgressMode::Bar
        } else {
            ProgressMode::Lines {
                every: Self::LOG_INTERVAL,
            }
        }
    }
}

pub struct Progress {
    mode: ProgressMode,
    bar: indicatif::ProgressBar,
    start: Instant,
    last_line: Instant,
    frames_total: u64,
    name: String,
}

/// "frames 120/361, 2.00 s simulated, 0.84× real time".
pub fn status(frames: u64, total: u64, sim_secs: f64, wall_secs: f64) -> String {
    format!(
        "frames {frames}/{total}, {sim_secs:.2} s simulated, {}× real time",
        realtime_factor(sim_secs, wall_secs)
    )
}

/// Simulated seconds per wall second, to three significant figures ("-" before any wall time).
pub fn realtime_factor(sim_secs: f64, wall_secs: f64) -> String {
    if wall_secs <= 0.0 {
        return "-".to_owned();
    }
    let f = sim_secs / wall_secs;
    if f >= 100.0 {
        format!("{f:.0}")
    } else if f >= 10.0 {
        format!("{f:.1}")
    } else if f >= 1.0 {
        format!("{f:.2}")
    } else if f >= 1e-3 || f == 0.0 {
        format!("{f:.3}")
    } else {
        // Slower still, as a power of ten: cloth-1024 on two cores runs at about 3e-4× real
        // time, which three decimals showed as 0.000×.
        format!("{f:.2e}")
    }
}

impl Progress {
    /// The frames of the run, the initial one included.
    pub fn frames_total(&self) -> u64 {
        self.frames_total
    }

    /// Progress over `frames_total` frames (the initial one included) of scene `name`.
    pub fn new(mode: ProgressMode, frames_total: u64, name: &str) -> Self {
        let bar = if mode == ProgressMode::Bar {
            indicatif::ProgressBar::new(frames_total).with_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} {prefix} [{bar:30}] {pos}/{len} frames, {per_sec}, {msg}, eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
            )
        } else {
            indicatif::ProgressBar::hidden()
        };
        bar.set_prefix(name.to_owned());
        let now = Instant::now();
        Self {
            mode,
            bar,
            start: now,
            last_line: now,
            frames_total,
            name: name.to_owned(),
        }
    }

    /// One more frame recorded, `sim_secs` into the run.
    pub fn frame(&mut self, frames_done: u64, sim_secs: f64) {
        let wall = self.start.elapsed().as_secs_f64();
        match self.mode {
            ProgressMode::Bar => {
                self.bar.set_position(frames_done);
                self.bar.set_message(format!(
                    "{sim_secs:.2} s simulated, {}× real time",
                    realtime_factor(sim_secs, wall)
                ));
            }
            ProgressMode::Lines { every } => {
                if self.last_line.elapsed() >= every {
                    self.last_line = Instant::now();
                    eprintln!(
                        "{}: {}",
                        self.name,
                        status(frames_done, self.frames_total, sim_secs, wall)
                    );
                }
            }
            ProgressMode::Off => {}
        }
    }

    /// Print `f`'s output without tearing the bar.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_status_line_names_frames_simulated_time_and_the_realtime_factor() {
        assert_eq!(
            status(120, 361, 2.0, 4.0),
            "frames 120/361, 2.00 s simulated, 0.500× real time"
        );
        assert_eq!(realtime_factor(30.0, 2.0), "15.0");
        assert_eq!(realtime_factor(1.0, 0.0), "-");
        assert_eq!(realtime_factor(0.0167, 52.0), "3.21e-4");
        assert_eq!(realtime_factor(0.0, 2.0), "0.000");
    }
}
