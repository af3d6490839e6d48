//! The command line: `hooke scenes | check | run | bench …`, and how its flags become a
//! [`Request`] for the library.

use clap::{Args, Parser, Subcommand};

use hooke::conformance::Verify;
use hooke::integrator::Integrator;
use hooke::run::prepare::{DtChoice, Request, SceneSource};
use hooke::run::select::{BackendKind, Device};
use hooke::scene::settings::Overrides;

#[derive(Debug, Parser)]
#[command(
    name = "hooke",
    version,
    about = "Mass-spring simulation (hair, cloth, jello) streamed to the Rerun viewer"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// List the built-in scenes.
    Scenes,
    /// Validate a scene and print its model, effects and stable step estimates.
    Check {
        /// Built-in scene name or path to a .toml scene file.
        scene: String,
        #[command(flatten)]
        solver: SolverArgs,
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Benchmarks (see BENCHMARKS.md).
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
    /// Many runs of one scene, its values varied, here or on a Slurm cluster.
    Sweep {
        #[command(subcommand)]
        which: super::sweep::SweepCommand,
    },
    /// Simulate a scene and stream it to Rerun (spawns the viewer unless told otherwise).
    Run {
        /// Built-in scene name or path to a .toml scene file.
        scene: String,
        #[command(flatten)]
        solver: SolverArgs,
        #[command(flatten)]
        device: DeviceArgs,
        #[command(flatten)]
        rerun: rerun::clap::RerunArgs,
        #[command(flatten)]
        output: OutputArgs,
        #[command(flatten)]
        recording: RecordingArgs,
        #[command(flatten)]
        compare: CompareArgs,
    },
}

/// A side-by-side comparison of solvers in one recording (`run`).
#[derive(Debug, Clone, clap::Args)]
pub struct CompareArgs {
    /// Run the scene under each entry, in one recording, the first the reference: an integrator,
    /// optionally with its own step, comma-separated: `rk4,xpbd,implicit@1/60` or
    /// `semi-implicit@dt=1e-4,semi-implicit@4e-4`. A scene's `[compare]` table is used when this
    /// is not given.
    #[arg(long, value_name = "ENTRIES")]
    pub compare: Option<String>,
    /// With a comparison: the copies on top of each other (the others translucent over the
    /// reference) instead of side by side.
    #[arg(long)]
    pub overlay: bool,
    /// With a comparison: what the copies other than the reference are coloured by when the
    /// recording opens (the other colouring is recorded too, one click away).
    #[arg(long, value_enum, default_value_t)]
    pub colour_by: hooke::record::ColourBy,
}

/// What the recording holds (`run`, `bench record`).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RecordedArgs {
    /// Which springs are logged as lines: all, structural (along the grid) or none. By default a
    /// strand logs all its springs, a sheet or block its structural springs when it has at most
    /// 5000 of them, and a larger one none (its surface only).
    #[arg(long, value_enum)]
    pub springs: Option<hooke::record::SpringSelection>,
    /// Also log the masses of sheets and blocks as points every frame (their surface is drawn
    /// through them anyway; pins always show).
    #[arg(long)]
    pub masses: bool,
    /// How much of a large sheet's or block's surface is recorded: auto (at most about 256
    /// vertices along each grid axis, every k-th vertex coloured by the most strained spring of
    /// its block) or full (every vertex).
    #[arg(long, value_enum, default_value_t)]
    pub surface: hooke::record::SurfaceDetail,
}

/// What the recording holds, and how fast it is made.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RecordingArgs {
    #[command(flatten)]
    pub recorded: RecordedArgs,
    /// Never run ahead of the wall clock: frame k is recorded no earlier than k / frame rate
    /// seconds after the start (for watching live). Without it the run goes as fast as it can.
    #[arg(long)]
    pub realtime: bool,
}

impl RecordingArgs {
    pub fn options(&self) -> hooke::record::RecordOptions {
        self.recorded.options()
    }
}

impl RecordedArgs {
    /// What the recording holds, in the default colours (`RecordOptions::for_scene` sets a
    /// scene's).
    pub fn options(&self) -> hooke::record::RecordOptions {
        hooke::record::RecordOptions {
            springs: self.springs,
            masses: self.masses,
            surface: self.surface,
            ..hooke::record::RecordOptions::default()
        }
    }
}

/// How the recording goes out, beside Rerun's own flags: where `--serve` listens (with Rerun's
/// `--bind` address), and how a `--save` file is written.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct OutputArgs {
    /// With --save: write the .rrd without its footer (the index of every chunk), which Rerun's
    /// file sink otherwise keeps in memory until the file closes, about 160 KB per second of a
    /// run. Use it for runs of hours; Rerun reads such a file, without the index.
    #[arg(long)]
    pub no_rrd_footer: bool,
    /// With --serve: the port of the gRPC server the web viewer reads the recording from.
    #[arg(long, default_value_t = 9876)]
    pub grpc_port: u16,
    /// With --serve: the port of the web viewer's page.
    #[arg(long, default_value_t = 9090)]
    pub web_viewer_port: u16,
}

#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// A long run through the whole pipeline (simulation, recorder, .rrd file) with resident
    /// memory sampled over time.
    Soak {
        #[arg(default_value = "hair")]
        scene: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Simulated seconds.
        #[arg(long, default_value_t = 600.0)]
        duration: f64,
        /// Where the recording goes.
        #[arg(long, default_value = "soak.rrd")]
        save: std::path::PathBuf,
        /// Write the .rrd without its footer index (see `hooke run --no-rrd-footer`).
        #[arg(long)]
        no_rrd_footer: bool,
    },
    /// Every integrator over a ladder of time steps against an f64 RK4 reference: error, energy
    /// drift, stability and wall time, as a table (Markdown, CSV) and a work-precision chart (SVG).
    Accuracy {
        /// Built-in scene name or .toml file.
        #[arg(default_value = "hair")]
        scene: String,
        #[command(flatten)]
        device: DeviceArgs,
        /// Simulated seconds each run covers.
        #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
        duration: f64,
        /// How many time steps: the scene's dt × 2^k, k = coarsest, coarsest − 1, …
        #[arg(long, default_value_t = 6)]
        points: u32,
        /// The largest of those steps is the scene's dt × 2^coarsest.
        #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
        coarsest: i32,
        /// Leave out the fast end: by default the ladder goes on doubling up to one step per
        /// frame (1/60 s at 60 frames/s), where only implicit Euler, VBD and XPBD survive.
        #[arg(long)]
        no_fast_end: bool,
        /// Timed runs of each point whose first run takes under a second; its wall time is their
        /// median (the physics of every run is the same, bit for bit). Single runs of
        /// milliseconds let noise pick the cheapest solver.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
        repeat: u32,
        /// Where the table, CSV and chart go.
        #[arg(long, default_value = "bench-out")]
        out: std::path::PathBuf,
        /// Also record the series to this .rrd file.
        #[arg(long)]
        save: Option<std::path::PathBuf>,
        /// Where the runs go: they are a sweep's points (OUT/accuracy-SCENE.sweep).
        #[command(flatten)]
        exec: super::sweep::ExecArgs,
    },
    /// Each integrator's estimated stable step (`hooke check`'s) against the largest
    /// stable step measured by bisection, per scene: the estimate must never overshoot.
    Stability {
        /// Built-in scene names or .toml files (default: every built-in scene but cloth-1024,
        /// whose searches take hours on a CPU; name it on a GPU machine with --backend gpu).
        scenes: Vec<String>,
        #[command(flatten)]
        device: DeviceArgs,
        /// Simulated seconds per trial.
        #[arg(long, default_value_t = 0.5)]
        duration: f64,
        /// Only these integrators (repeat the flag; default: every one).
        #[arg(long = "integrator", value_enum)]
        integrators: Vec<Integrator>,
        /// Also write the table to this Markdown file.
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
    /// The recorder alone, on frames made without stepping: bytes per frame per entity, frames/s
    /// sustained into an .rrd file and into a sink that discards, and peak memory.
    Record {
        /// Built-in scene name or .toml file.
        #[arg(default_value = "cloth-256")]
        scene: String,
        /// Frames recorded in each pass.
        #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u64).range(1..))]
        frames: u64,
        /// The .rrd file the file pass writes.
        #[arg(long, default_value = "bench-record.rrd")]
        save: std::path::PathBuf,
        #[command(flatten)]
        recording: RecordedArgs,
    },
    /// Step scenes headless with no recording and report steps/s and spring updates/s.
    Throughput {
        /// Built-in scene names or .toml files (default: cloth-64 cloth-256).
        scenes: Vec<String>,
        #[command(flatten)]
        device: DeviceArgs,
        /// Integrator (default: each scene's own).
        #[arg(long, value_enum)]
        integrator: Option<Integrator>,
        /// Timed steps per scene (after a warm-up).
        #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..))]
        steps: u32,
        /// Steps per GPU submission.
        #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..))]
        batch: u32,
        /// Also time each scene without each of its effects in turn: what each effect costs.
        #[arg(long)]
        effects: bool,
        /// Timed runs of --steps steps each, after one warm-up: prints their median and spread.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
        repeat: u32,
        /// Print one JSON object per line for each scene instead of text (for scripts).
        #[arg(long, conflicts_with = "effects")]
        json: bool,
        /// Implicit Euler's and BDF2's CG preconditioner (default: the scene's, else
        /// multigrid from 4 096 masses).
        #[arg(long, value_enum)]
        preconditioner: Option<hooke::physics::Preconditioner>,
    },
}

/// Which backend steps the simulation, and on which adapter.
#[derive(Debug, Clone, Args)]
pub struct DeviceArgs {
    /// The backend: wgpu compute on a GPU adapter, or the multi-threaded CPU reference.
    #[arg(long, value_enum, default_value_t = BackendKind::Gpu)]
    pub backend: BackendKind,
    /// Use the GPU adapter whose name contains this (`hooke check` names the one chosen).
    #[arg(long)]
    pub adapter: Option<String>,
    /// Probe the adapter's kernels for this run against the CPU reference even where a verdict
    /// is kept (the first run on an adapter does it once per kernel family; `check --verify`
    /// prints the verdicts).
    #[arg(long, conflicts_with = "no_verify")]
    pub verify: bool,
    /// Step on the GPU without the conformance probe, even on an adapter never probed or one
    /// found to disagree with the CPU.
    #[arg(long)]
    pub no_verify: bool,
}

/// Solver settings; each overrides the scene file's value.
#[derive(Debug, Args)]
pub struct SolverArgs {
    /// Time integrator.
    #[arg(long, value_enum)]
    pub integrator: Option<Integrator>,
    /// Step size in seconds, as a number or a fraction (`1/60`; the substeps per frame follow
    /// from it), or `auto`: substeps chosen
    /// from the stability estimate and --tolerance, measured by step doubling on a short probe.
    #[arg(long, conflicts_with = "substeps", allow_negative_numbers = true, value_parser = parse_dt)]
    pub dt: Option<Dt>,
    /// With --dt auto: the RMS position error (m) allowed over the probe.
    #[arg(long, default_value_t = 1e-3)]
    pub tolerance: f64,
    /// Steps per frame (dt = 1 / (frame rate × substeps)).
    #[arg(long)]
    pub substeps: Option<u32>,
    /// Number of frames to simulate after the initial one.
    #[arg(long, conflicts_with = "duration")]
    pub frames: Option<u64>,
    /// Simulated time in seconds.
    #[arg(long, allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// With --integrator xpbd: constraint iterations per substep (default 1: many substeps of
    /// one iteration each are cheaper for the same accuracy).
    #[arg(long, allow_negative_numbers = true)]
    pub xpbd_iterations: Option<u32>,
    /// With --integrator vbd: sweeps over the masses per step (default 10).
    #[arg(long, allow_negative_numbers = true)]
    pub vbd_iterations: Option<u32>,
    /// With --integrator implicit or bdf2: what preconditions the conjugate gradients on both
    /// backends (default: multigrid from 4 096 masses, block Jacobi below).
    #[arg(long, value_enum)]
    pub preconditioner: Option<hooke::physics::Preconditioner>,
}

/// `--dt`: seconds, or `auto`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Dt {
    Secs(f64),
    Auto,
}

fn parse_dt(s: &str) -> Result<Dt, String> {
    if s == "auto" {
        return Ok(Dt::Auto);
    }
    hooke::scene::compare_entry::seconds(s)
        .map(Dt::Secs)
        .ok_or_else(|| format!("expected seconds (like 0.001 or 1/60) or `auto`, got '{s}'"))
}

impl DeviceArgs {
    /// The device these flags name; a GPU flag given with `--backend cpu` is noted as ignored.
    pub fn device(&self) -> Device {
        if self.backend == BackendKind::Cpu {
            let gpu_only = [
                (self.adapter.is_some(), "--adapter"),
                (self.verify, "--verify"),
                (self.no_verify, "--no-verify"),
            ];
            for (_, flag) in gpu_only.into_iter().filter(|(given, _)| *given) {
                eprintln!("note: {flag} is for the GPU backend; --backend cpu ignores it");
            }
        }
        Device {
            kind: self.backend,
            adapter: self.adapter.clone(),
            verify: match (self.verify, self.no_verify) {
                (true, _) => Verify::Always,
                (_, true) => Verify::Never,
                _ => Verify::Unseen,
            },
        }
    }
}

impl SolverArgs {
    /// What to prepare: `scene` with these settings on `device`.
    pub fn request(&self, scene: &str, device: &DeviceArgs) -> Request {
        Request {
            scene: SceneSource::Named(scene.to_owned()),
            overrides: self.overrides(),
            dt: match self.dt {
                Some(Dt::Auto) => DtChoice::Auto {
                    tolerance_m: self.tolerance,
                },
                _ => DtChoice::AsGiven,
            },
            device: device.device(),
        }
    }

    pub fn overrides(&self) -> Overrides {
        Overrides {
            integrator: self.integrator,
            dt_secs: match self.dt {
                Some(Dt::Secs(s)) => Some(s),
                _ => None,
            },
            substeps: self.substeps,
            frames: self.frames,
            duration_secs: self.duration,
            xpbd_iterations: self.xpbd_iterations,
            vbd_iterations: self.vbd_iterations,
            preconditioner: self.preconditioner,
        }
    }
}
