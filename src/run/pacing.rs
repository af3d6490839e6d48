//! `--realtime`: a live view that never runs ahead of the wall clock.
//!
//! [`paced`] wraps a backend and holds each snapshot until its time has come: frame k is handed
//! out no earlier than k / frame_rate seconds of wall time after the first. A run that cannot keep
//! up simply runs late; nothing is skipped to catch up.

use std::time::{Duration, Instant};

use crate::backend::{Backend, Then};
use crate::state::Snapshot;

/// The wall-clock schedule of frames.
#[derive(Debug, Clone, Copy)]
pub struct Pacer {
    start: Instant,
    frame_rate_hz: f64,
}

impl Pacer {
    /// Frame 0 is due now.
    pub fn start(frame_rate_hz: f64) -> Self {
        Self {
            start: Instant::now(),
            frame_rate_hz,
        }
    }

    /// When frame `frame` is due, from the start.
    pub fn due(&self, frame: u64) -> Duration {
        Duration::from_secs_f64(frame as f64 / self.frame_rate_hz)
    }

    /// Sleep until frame `frame` is due (at once if it is already).
    pub fn wait_for(&self, frame: u64) {
        let due = self.start + self.due(frame);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
    }

    pub fn started(&self) -> Instant {
        self.start
    }
}

/// `inner`, its snapshots released on the wall clock's schedule. Stepping is not held back: the
/// next frame is stepped while this one waits (one frame ahead at most, since the simulation
/// thread waits on each snapshot).
pub fn paced(inner: Box<dyn Backend>, pacer: Pacer) -> Box<dyn Backend> {
    Box::new(Then::new(inner, move |s: &mut Snapshot| {
        pacer.wait_for(s.frame);
        Ok(())
    }))
}

/// Frames a run records before it judges whether the recorder sets the pace.
const PACE_WARM_UP_FRAMES: u64 = 30;

/// Recording time before the recorder is judged.
const PACE_MIN_BUSY: Duration = Duration::from_millis(500);

/// The simulation's side of a run's pace: how long it takes to make a frame by itself (stepping
/// and reading back, not waiting for the recorder). Written by the simulation thread, read by
/// the recorder's.
#[derive(Debug, Default)]
pub struct SimPace {
    frames: std::sync::atomic::AtomicU64,
    nanos: std::sync::atomic::AtomicU64,
    /// A substep's wall time in the last chunk of a long frame (nanoseconds; 0: none yet).
    substep_nanos: std::sync::atomic::AtomicU64,
    /// The substeps of that frame.
    frame_substeps: std::sync::atomic::AtomicU64,
}

impl SimPace {
    /// A chunk of a frame of `frame_substeps` took `per_substep` a substep.
    pub fn stepped(&self, frame_substeps: u32, per_substep: Duration) {
        use std::sync::atomic::Ordering::Relaxed;
        let nanos = u64::try_from(per_substep.as_nanos()).unwrap_or(u64::MAX);
        self.substep_nanos.store(nanos.max(1), Relaxed);
        self.frame_substeps
            .store(u64::from(frame_substeps), Relaxed);
    }

    /// A frame's substeps, and one substep's wall time, as the last chunk measured them.
    fn substeps(&self) -> Option<(u64, Duration)> {
        use std::sync::atomic::Ordering::Relaxed;
        let (n, nanos) = (
            self.frame_substeps.load(Relaxed),
            self.substep_nanos.load(Relaxed),
        );
        (nanos > 0).then(|| (n, Duration::from_nanos(nanos)))
    }

    /// One more frame, made in `took`.
    pub fn made(&self, took: Duration) {
        use std::sync::atomic::Ordering::Relaxed;
        self.nanos
            .fetch_add(u64::try_from(took.as_nanos()).unwrap_or(u64::MAX), Relaxed);
        self.frames.fetch_add(1, Relaxed);
    }

    /// Frames per second the simulation makes by itself, once it has made some.
    fn frames_per_sec(&self) -> Option<f64> {
        use std::sync::atomic::Ordering::Relaxed;
        let (frames, nanos) = (self.frames.load(Relaxed), self.nanos.load(Relaxed));
        (frames > 0 && nanos > 0).then(|| frames as f64 / (nanos as f64 * 1e-9))
    }
}

/// The recorder's side: the time it spends on each frame. It says once, with both rates, when
/// the recorder is what holds the run back, instead of letting the run go slower in silence.
#[derive(Debug, Default)]
pub struct RecorderPace {
    frames: u64,
    busy: Duration,
    said: bool,
}

impl RecorderPace {
    /// One more frame recorded in `took`: the sentence to say, the first time the recorder
    /// (after a warm-up) makes frames at under 80% of the simulation's rate.
    pub fn recorded(&mut self, took: Duration, sim: &SimPace) -> Option<RecorderSlow> {
        self.frames += 1;
        self.busy += took;
        // A run whose recording takes under half a second in all is not held back to speak of.
        if self.said || self.frames < PACE_WARM_UP_FRAMES || self.busy < PACE_MIN_BUSY {
            return None;
        }
        let recorder = self.frames as f64 / self.busy.as_secs_f64();
        let simulation = sim.frames_per_sec()?;
        (recorder < 0.8 * simulation).then(|| {
            self.said = true;
            RecorderSlow {
                recorder_fps: recorder,
                simulation_fps: simulation,
            }
        })
    }
}

/// The recorder makes frames slower than the simulation: it holds the run back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecorderSlow {
    pub recorder_fps: f64,
    pub simulation_fps: f64,
}

impl std::fmt::Display for RecorderSlow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the recorder is holding the run back: it records {:.1} frames/s, the simulation \
             makes {:.1}; lighter frames go faster (--surface auto, the default, fewer --springs, \
             no --masses)",
            self.recorder_fps, self.simulation_fps
        )
    }
}

/// A frame that takes longer than this is said, with what it will take.
pub const LONG_FRAME: Duration = Duration::from_secs(10);

/// What the recorder says, once, when frames are long: how long each takes as measured and what
/// the run will take, or that one step has run for [`LONG_FRAME`] and is not done (a step of many
/// sweeps). A run of frames this long is most likely a setting the user did not mean.
#[derive(Debug)]
pub struct LongFrames {
    last_frame: Instant,
    said: bool,
}

impl Default for LongFrames {
    fn default() -> Self {
        Self {
            last_frame: Instant::now(),
            said: false,
        }
    }
}

impl LongFrames {
    /// A frame arrived.
    pub fn frame(&mut self) {
        self.last_frame = Instant::now();
    }

    /// What to say, with `frames_left` frames to go, while the recorder waits for a frame.
    pub fn waiting(&mut self, sim: &SimPace, frames_left: u64) -> Option<LongFrame> {
        let waited = self.last_frame.elapsed();
        if self.said || waited < LONG_FRAME {
            return None;
        }
        self.said = true;
        Some(match sim.substeps() {
            Some((substeps, each)) => LongFrame::Measured {
                substeps,
                each_secs: each.as_secs_f64(),
                frames_left,
            },
            None => LongFrame::FirstSubstep {
                waited_secs: waited.as_secs_f64(),
            },
        })
    }
}

/// Frames are long, as [`LongFrames::waiting`] finds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LongFrame {
    /// Each of `substeps` substeps takes `each_secs`, as measured.
    Measured {
        substeps: u64,
        each_secs: f64,
        frames_left: u64,
    },
    /// The frame's first substep has run `waited_secs` and is not done.
    FirstSubstep { waited_secs: f64 },
}

impl std::fmt::Display for LongFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let stop = "Ctrl-C stops the run within half a second and keeps every finished frame";
        match *self {
            LongFrame::Measured {
                substeps,
                each_secs,
                frames_left,
            } => {
                let frame = each_secs * substeps as f64;
                write!(
                    f,
                    "a frame takes about {} here ({substeps} substeps of {each_secs:.3e} s each, \
                     as measured), so the {frames_left} frames left take about {}: {stop}; fewer \
                     substeps (a larger --dt) or fewer sweeps make frames shorter",
                    human_secs(frame),
                    human_secs(frame * frames_left as f64),
                )
            }
            LongFrame::FirstSubstep { waited_secs } => write!(
                f,
                "the next frame has taken {} so far and its first substep is not done (a step \
                 this long does a great deal of work: many sweeps, or a very large scene): {stop}",
                human_secs(waited_secs),
            ),
        }
    }
}

/// `secs` in the unit a person reads best: "42 s", "3.5 min", "7.2 h", "12 d".
fn human_secs(secs: f64) -> String {
    match secs {
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.1} min", s / 60.0),
        s if s < 172_800.0 => format!("{:.1} h", s / 3600.0),
        s if s < 3.2e8 => format!("{:.0} d", s / 86_400.0),
        s => format!("{:.0e} years", s / 3.156e7),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_frame_is_said_once_with_its_measured_length() {
        let sim = SimPace::default();
        let mut long = LongFrames {
            last_frame: Instant::now() - LONG_FRAME,
            said: false,
        };
        sim.stepped(1_000_000, Duration::from_micros(300));
        let said = long.waiting(&sim, 10).expect("said");
        assert_eq!(
            said,
            LongFrame::Measured {
                substeps: 1_000_000,
                each_secs: 3e-4,
                frames_left: 10
            }
        );
        let said = said.to_string();
        assert!(
            said.contains("a frame takes about 5.0 min")
                && said.contains("1000000 substeps of 3.000e-4 s")
                && said.contains("the 10 frames left take about 50.0 min"),
            "{said}"
        );
        assert_eq!(long.waiting(&sim, 10), None, "once");
        // Before any substep is done, how long the frame has run so far.
        let mut first = LongFrames {
            last_frame: Instant::now() - LONG_FRAME,
            said: false,
        };
        let said = first.waiting(&SimPace::default(), 10).expect("said");
        assert!(matches!(said, LongFrame::FirstSubstep { waited_secs } if waited_secs >= 10.0));
        assert!(said.to_string().contains("its first substep is not done"));
        // A frame shorter than LONG_FRAME says nothing.
        assert_eq!(LongFrames::default().waiting(&sim, 10), None);
    }

    #[test]
    fn the_recorder_is_named_once_when_it_is_the_slower_side() {
        let sim = SimPace::default();
        let mut rec = RecorderPace::default();
        // The simulation makes a frame in 5 ms (200 frames/s), the recorder takes 20 ms.
        for _ in 0..PACE_WARM_UP_FRAMES - 1 {
            sim.made(Duration::from_millis(5));
            assert_eq!(rec.recorded(Duration::from_millis(20), &sim), None);
        }
        let said = rec.recorded(Duration::from_millis(20), &sim).expect("said");
        assert!(
            (said.recorder_fps - 50.0).abs() < 1e-9 && (said.simulation_fps - 200.0).abs() < 1e-9,
            "{said:?}"
        );
        let said = said.to_string();
        assert!(
            said.contains("50.0 frames/s") && said.contains("200.0"),
            "{said}"
        );
        assert_eq!(rec.recorded(Duration::from_millis(20), &sim), None, "once");
        // A recorder as fast as the simulation says nothing.
        let mut quick = RecorderPace::default();
        for _ in 0..200 {
            assert_eq!(quick.recorded(Duration::from_millis(5), &sim), None);
        }
        // Nor does a slower recorder in a run too short to matter.
        let mut brief = RecorderPace::default();
        for _ in 0..100 {
            assert_eq!(
                brief.recorded(Duration::from_millis(1), &SimPace::default()),
                None
            );
        }
    }
}
