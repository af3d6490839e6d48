//! `hooke run`: prepare the scene, open the sink, step and record until done or interrupted,
//! and say how it went. With `--stdout` the recording owns standard output, so everything said
//! here goes to standard error.

use std::io::IsTerminal as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use hooke::run::prepare::{self, Prepared};
use hooke::scene::compare_entry::CompareEntry;

use super::args::{CompareArgs, DeviceArgs, OutputArgs, RecordingArgs, SolverArgs};
use super::outcome::Outcome;
use super::sink::{self, Sink};

/// What `hooke run` was given.
pub struct RunArgs<'a> {
    pub scene: &'a str,
    pub solver: &'a SolverArgs,
    pub device: &'a DeviceArgs,
    pub rerun: &'a rerun::clap::RerunArgs,
    pub output: &'a OutputArgs,
    pub recording: &'a RecordingArgs,
    pub compare: &'a CompareArgs,
    /// The `run` subcommand's matches: which of Rerun's flags were given.
    pub matches: &'a clap::ArgMatches,
}

pub fn run(args: &RunArgs<'_>) -> anyhow::Result<Outcome> {
    let request = args.solver.request(args.scene, args.device);
    if let Some(compare) = comparison(args, &request)? {
        return run_comparison(args, &request, compare);
    }
    let prepared = prepare::prepare(&request, &mut |notice| eprintln!("{notice}"))?;
    let record = args.recording.options().for_scene(&prepared.loaded.scene);
    describe(&prepared, &record);
    // Before the file exists: an interrupt from here on ends the run with the file renamed
    // into place, never a process killed with only its `.partial` left.
    let interrupts = Interrupts::install();
    let (sink, opts) = open(args, &prepared.loaded.scene.name, record)?;
    if let Some(file) = &sink.file {
        let size =
            hooke::run::recording_size::estimate(&prepared.model, &prepared.settings, record)?;
        eprintln!(
            "{}",
            hooke::run::recording_size::describe_for_file(
                &size,
                prepared.settings.frames,
                file.path()
            )
        );
    }
    let result = hooke::run::run(prepared, sink.rec.clone(), &opts, interrupts.cancel.clone());
    say_where_saved(&sink, &result);
    let summary = result?;
    report(&summary);
    if summary.cancelled {
        return Ok(Outcome::Interrupted);
    }
    if let Some(serving) = &sink.serving {
        interrupts.serve_until_interrupted(&serving.page);
    }
    Ok(Outcome::Done)
}

/// Where the run records (Rerun's flags), and how: the options of the two threads.
fn open(
    args: &RunArgs<'_>,
    scene: &str,
    record: hooke::record::RecordOptions,
) -> anyhow::Result<(Sink, hooke::run::RunOptions)> {
    let sink = sink::open_sink(args.rerun, args.output, args.matches, scene)?;
    let opts = hooke::run::RunOptions {
        delivery: sink.delivery,
        progress: hooke::run::progress::ProgressMode::for_stderr(std::io::stderr().is_terminal()),
        realtime: args.recording.realtime,
        record,
        viewer: sink.viewer.clone(),
        file: sink.file.clone(),
    };
    Ok((sink, opts))
}

/// The most entries a comparison holds.
const MOST_COMPARED: usize = 16;

/// The comparison a run asks for: `--compare`'s entries, else the scene's `[compare]` table's;
/// `None` for a single run. The entries are checked here, each failure named by its position.
fn comparison(
    args: &RunArgs<'_>,
    request: &prepare::Request,
) -> anyhow::Result<Option<(Vec<CompareEntry>, Option<hooke::scene::Compare>)>> {
    let table = match (&args.compare.compare, &request.scene) {
        (Some(_), _) => None,
        (None, prepare::SceneSource::Named(name)) => hooke::scene::load(name)?.scene.compare,
        (None, prepare::SceneSource::Variant(scene)) => scene.compare.clone(),
        (None, prepare::SceneSource::Loaded(loaded)) => loaded.scene.compare.clone(),
    };
    let texts: Vec<String> = match (&args.compare.compare, &table) {
        (Some(list), _) => list.split(',').map(str::to_owned).collect(),
        (None, Some(t)) => t.entries.clone(),
        (None, None) => {
            // Options that shape a comparison do nothing in a single run: said, not ignored.
            let given = ["overlay", "colour_by"]
                .into_iter()
                .find(|id| sink::explicit(args.matches, id));
            if let Some(id) = given {
                anyhow::bail!(
                    "--{} shapes a comparison, and this run compares nothing: add --compare \
                     ENTRIES (or a [compare] table in the scene), or leave it out",
                    id.replace('_', "-")
                );
            }
            return Ok(None);
        }
    };
    if texts.len() > MOST_COMPARED {
        anyhow::bail!(
            "--compare has {} entries; a comparison holds at most {MOST_COMPARED}: each entry is \
             a whole run stepped beside the others, with its own copy of the scene in the \
             recording and the viewer (1 000 entries of a 64-mass scene took 68 s and 1 GB). \
             Split it into several runs",
            texts.len()
        );
    }
    if request.overrides.integrator.is_some() {
        anyhow::bail!(
            "--integrator and a comparison do not go together: each --compare entry names its integrator"
        );
    }
    if request.dt != prepare::DtChoice::AsGiven {
        anyhow::bail!(
            "--dt auto and a comparison do not go together: give an entry its step as rk4@1e-4"
        );
    }
    let entries = texts
        .iter()
        .enumerate()
        .map(|(i, t)| {
            CompareEntry::parse(t).map_err(|why| hooke::Error::CompareEntry {
                position: i + 1,
                text: t.trim().to_owned(),
                why,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Some((entries, table)))
}

/// `hooke run --compare`: every entry in one recording, and a line per entry at the end.
fn run_comparison(
    args: &RunArgs<'_>,
    request: &prepare::Request,
    (entries, table): (Vec<CompareEntry>, Option<hooke::scene::Compare>),
) -> anyhow::Result<Outcome> {
    let prepared =
        prepare::prepare_comparison(request, &entries, &mut |notice| eprintln!("{notice}"))?;
    let record = args.recording.options().for_scene(&prepared.loaded.scene);
    let layout = hooke::record::CompareLayout {
        overlay: args.compare.overlay || table.as_ref().is_some_and(|t| t.overlay),
        gap_range_m: table
            .as_ref()
            .and_then(|t| t.gap_range_m)
            .unwrap_or_else(|| hooke::record::CompareLayout::default_gap_range(&prepared.model)),
        colour_by: args.compare.colour_by,
    };
    let first = prepared.entries.first().map(|e| e.backend.describe());
    eprintln!(
        "hooke: '{}' with {} masses and {} springs on {}, compared under {} entries ({}), gap scale {:.3} m:",
        prepared.loaded.scene.name,
        prepared.model.mass_count(),
        prepared.model.spring_count(),
        first.unwrap_or_default(),
        prepared.entries.len(),
        if layout.overlay {
            "overlaid"
        } else {
            "side by side"
        },
        layout.gap_range_m
    );
    for e in &prepared.entries {
        eprintln!(
            "  {:<24} {}, dt = {:.3e} s × {} substeps, {} frames",
            e.name,
            e.settings.integrator,
            e.settings.dt_secs,
            e.settings.substeps,
            e.settings.frames
        );
    }
    let interrupts = Interrupts::install();
    let (sink, opts) = open(args, &prepared.loaded.scene.name, record)?;
    let result = hooke::run::comparison::run_comparison(
        prepared,
        sink.rec.clone(),
        &opts,
        layout,
        interrupts.cancel.clone(),
    );
    say_where_saved(&sink, &result);
    let summary = result?;
    eprintln!(
        "{}: {} frames in {:.2} s wall; per entry:",
        if summary.cancelled {
            "interrupted"
        } else {
            "done"
        },
        summary.frames_recorded,
        summary.wall_secs
    );
    for (i, e) in summary.entries.iter().enumerate() {
        eprintln!("  {}", e.line(i == 0));
    }
    for e in &summary.entries {
        if let Some((frame, why)) = &e.stopped {
            eprintln!(
                "error: entry {} stopped at frame {frame}: {why}",
                e.tally.name
            );
        }
    }
    if summary.cancelled {
        return Ok(Outcome::Interrupted);
    }
    if let Some(serving) = &sink.serving {
        interrupts.serve_until_interrupted(&serving.page);
    }
    Ok(Outcome::Done)
}

/// The run about to start, and what its recording holds.
fn describe(p: &Prepared, record: &hooke::record::RecordOptions) {
    eprintln!(
        "hooke: '{}' with {} masses and {} springs on {}, {}, dt = {:.3e} s × {} substeps, {} frames",
        p.loaded.scene.name,
        p.model.mass_count(),
        p.model.spring_count(),
        p.backend.describe(),
        p.settings.integrator,
        p.settings.dt_secs,
        p.settings.substeps,
        p.settings.frames
    );
    for line in hooke::record::describe(&p.model, record) {
        eprintln!("  recording {line}");
    }
}

/// Where the recording is, whether the run went well or not.
fn say_where_saved<T>(sink: &Sink, result: &hooke::Result<T>) {
    let Some(p) = &sink.saved else {
        return;
    };
    let open = format!("open it with `rerun {}`", p.display());
    match result {
        Ok(_) => eprintln!("saved {}; {open}", p.display()),
        // Its own message says what the file holds.
        Err(hooke::Error::WriteRecording(_)) => {}
        Err(_) => eprintln!(
            "the frames recorded before the error are in {}; {open}",
            p.display()
        ),
    }
}

fn report(summary: &hooke::run::RunSummary) {
    eprintln!(
        "{}: {} frames ({:.3} s simulated) in {:.2} s wall{}",
        if summary.cancelled {
            "interrupted"
        } else {
            "done"
        },
        summary.frames_recorded,
        summary.sim_time_secs,
        summary.wall_secs,
        if summary.frames_dropped > 0 {
            format!(
                ", {} frames not shown because the viewer fell behind",
                summary.frames_dropped
            )
        } else {
            String::new()
        }
    );
}

/// Ctrl-C and SIGTERM. The first stops stepping within a chunk of substeps (the frame in
/// progress is dropped), records every frame already produced and ends the file; a second one
/// ends the process at once. After the run, with `--serve`, an interrupt just ends the serving.
struct Interrupts {
    cancel: Arc<AtomicBool>,
    serving_only: Arc<AtomicBool>,
}

impl Interrupts {
    fn install() -> Self {
        let cancel = Arc::new(AtomicBool::new(false));
        let serving_only = Arc::new(AtomicBool::new(false));
        let installed = ctrlc::set_handler({
            let cancel = cancel.clone();
            let serving_only = serving_only.clone();
            move || {
                if serving_only.load(Ordering::SeqCst) {
                    cancel.store(true, Ordering::SeqCst);
                    return;
                }
                if cancel.swap(true, Ordering::SeqCst) {
                    eprintln!(
                        "second interrupt: exiting without finishing the recording (its whole frames keep the file's name, without an index)"
                    );
                    hooke::record::rrd_file::rename_unfinished();
                    std::process::exit(130);
                }
                eprintln!(
                    "interrupted: stopping now, dropping the frame in progress and saving every finished frame (again to quit at once)"
                );
            }
        });
        if let Err(e) = installed {
            eprintln!(
                "warning: cannot catch Ctrl-C ({e}); an interrupt will end the run without flushing"
            );
        }
        Self {
            cancel,
            serving_only,
        }
    }

    /// Keep the served recording up until the next interrupt.
    fn serve_until_interrupted(&self, page: &str) {
        self.serving_only.store(true, Ordering::SeqCst);
        eprintln!("the recording stays served at {page} until Ctrl-C");
        while !self.cancel.load(Ordering::SeqCst) {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        eprintln!("stopped serving");
    }
}
