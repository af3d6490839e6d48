//! The `hooke` binary: parse the command line, call the library, print errors as one message.

mod cli;

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context as _;
use clap::{CommandFactory as _, FromArgMatches as _};

use cli::{Cli, Command};
use hooke::scene;
use hooke::settings::Settings;
use hooke::sim::Delivery;

fn main() -> std::process::ExitCode {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: no other thread exists yet. Mesa's drivers print a misleading "error:" line on
        // every run without a runtime dir (headless servers, CI); /tmp serves them.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    #[cfg(unix)]
    // SAFETY: no other thread exists yet. A file-size limit (ulimit -f) would otherwise kill the
    // process mid-write; ignored, the write fails and the run reports it like a full disk.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    let matches = Cli::command().get_matches();
    let result = Cli::from_arg_matches(&matches)
        .map_err(anyhow::Error::from)
        .and_then(|cli| dispatch(cli, &matches));
    match result {
        Ok(Outcome::Done) => std::process::ExitCode::SUCCESS,
        // The shell's convention for a run ended by SIGINT.
        Ok(Outcome::Interrupted) => std::process::ExitCode::from(130),
        Err(e) => {
            eprintln!("error: {}", one_message(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// An error and its causes as one line, each cause said once: many libraries' errors repeat
/// their cause in their own message *and* return it as their source, so printing the chain as
/// it is says the same thing two or three times.
fn one_message(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if message.contains(text.trim()) {
            continue;
        }
        if !message.is_empty() {
            message.push_str(": ");
        }
        message.push_str(&text);
    }
    message
}

/// How a command ended without error.
enum Outcome {
    Done,
    /// Ctrl-C or SIGTERM stopped a run; everything produced before it was recorded.
    Interrupted,
}

fn dispatch(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<Outcome> {
    match cli.command {
        Command::Scenes => {
            for b in scene::BUILT_IN {
                let s =
                    scene::from_toml(b.toml, hooke::error::SceneOrigin::BuiltIn(b.name.into()))?;
                println!("{:<14} {}", b.name, s.description);
            }
            println!(
                "\nEach is also a file under examples/scenes/; `hooke run FILE.toml` runs a copy you edit."
            );
            Ok(Outcome::Done)
        }
        Command::Check {
            scene,
            solver,
            device: cli::DeviceArgs { backend, adapter },
        } => {
            let (loaded, settings, model) =
                prepare(&scene, &solver, backend, adapter.as_deref(), |m| {
                    println!("{m}")
                })?;
            print!(
                "{}",
                hooke::check::report(&loaded.scene.name, &model, &settings)
            );
            let size = hooke::recording_size::estimate(
                &model,
                &settings,
                loaded.scene.view.strain_range,
                hooke::record::RecordOptions::default(),
            )?;
            println!(
                "recording (estimated from sample frames, default --springs): about {} per frame, {} for all {} frames",
                hooke::rrd_file::human_bytes(size.bytes_per_frame),
                hooke::rrd_file::human_bytes(size.total(settings.frames)),
                settings.frames + 1
            );
            match backend {
                hooke::select::BackendKind::Cpu => {
                    println!("backend: cpu ({} threads)", rayon::current_num_threads())
                }
                hooke::select::BackendKind::Gpu => {
                    match hooke::gpu::adapter_report(
                        adapter.as_deref(),
                        &model,
                        settings.integrator,
                    ) {
                        Ok(line) => println!("{line}"),
                        Err(e) => println!("warning: {e}"),
                    }
                }
            }
            Ok(Outcome::Done)
        }
        Command::Bench {
            which:
                cli::BenchCommand::Soak {
                    scene,
                    device: cli::DeviceArgs { backend, adapter },
                    duration,
                    save,
                    no_rrd_footer,
                },
        } => {
            let s = hooke::bench::soak(
                &scene,
                backend,
                adapter.as_deref(),
                duration,
                &save,
                !no_rrd_footer,
            )?;
            println!("{}", hooke::bench::format_soak(&s));
            Ok(Outcome::Done)
        }
        Command::Bench {
            which:
                cli::BenchCommand::Accuracy {
                    scene,
                    device: cli::DeviceArgs { backend, adapter },
                    duration,
                    points,
                    coarsest,
                    out,
                    save,
                },
        } => {
            let opts = hooke::accuracy::AccuracyOptions {
                backend,
                adapter,
                duration_secs: duration,
                points,
                coarsest,
                out_dir: out.clone(),
                rrd: save.clone(),
            };
            let report = hooke::accuracy::accuracy(&scene, &opts)?;
            println!("{}", hooke::accuracy::markdown(&report));
            println!(
                "wrote {0}/accuracy-{1}.md, .csv and .svg (the work-precision chart){2}",
                out.display(),
                report.scene,
                save.map(|p| format!("; recording {}", p.display()))
                    .unwrap_or_default()
            );
            Ok(Outcome::Done)
        }
        Command::Bench {
            which:
                cli::BenchCommand::Record {
                    scene,
                    frames,
                    save,
                    recording,
                },
        } => {
            let opts = hooke::bench::RecordBenchOptions {
                frames,
                record: recording.options(),
                save,
            };
            let b = hooke::bench::record(&scene, &opts)?;
            println!("{}", hooke::bench::format_record(&b));
            Ok(Outcome::Done)
        }
        Command::Bench {
            which:
                cli::BenchCommand::Throughput {
                    scenes,
                    device: cli::DeviceArgs { backend, adapter },
                    integrator,
                    steps,
                    batch,
                    effects,
                },
        } => {
            let scenes = if scenes.is_empty() {
                vec!["cloth-64".to_owned(), "cloth-256".to_owned()]
            } else {
                scenes
            };
            let opts = hooke::bench::ThroughputOptions {
                backend,
                adapter,
                integrator,
                steps,
                batch,
            };
            for s in &scenes {
                if effects {
                    let c = hooke::bench::effect_costs(s, &opts)?;
                    println!("{}", hooke::bench::format_effect_costs(&c));
                } else {
                    let t = hooke::bench::throughput(s, &opts)?;
                    println!("{}", hooke::bench::format_throughput(&t));
                }
            }
            Ok(Outcome::Done)
        }
        Command::Run {
            scene,
            solver,
            device: cli::DeviceArgs { backend, adapter },
            rerun,
            output,
            recording,
        } => {
            let run_matches = matches
                .subcommand_matches("run")
                .context("parsing `run` arguments")?;
            run(
                &scene,
                &solver,
                (backend, adapter),
                (&rerun, &output),
                &recording,
                run_matches,
            )
        }
    }
}

/// Load a scene, resolve its settings with the command line's (`--dt auto` included) and build
/// its model, telling `say` what the user should know about how their values were applied.
fn prepare(
    scene_arg: &str,
    solver: &cli::SolverArgs,
    kind: hooke::select::BackendKind,
    adapter: Option<&str>,
    say: impl Fn(&str),
) -> anyhow::Result<(scene::LoadedScene, Settings, Arc<hooke::model::Model>)> {
    let loaded = scene::load(scene_arg)?;
    let mut settings = Settings::resolve(&loaded.scene, &solver.overrides())?;
    for n in &settings.notes {
        say(&format!("note: {n}"));
    }
    let model = Arc::new(hooke::model::build(&loaded.scene));
    if solver.dt == Some(cli::Dt::Auto) {
        let tolerance = solver.tolerance;
        if !(tolerance.is_finite() && tolerance > 0.0) {
            anyhow::bail!("--tolerance must be a positive number of metres, got {tolerance}");
        }
        let auto = hooke::auto_dt::choose(&model, &settings, kind, adapter, tolerance)?;
        say(&auto.to_string());
        settings.substeps = auto.substeps;
        settings.dt_secs = auto.dt_secs;
    }
    Ok((loaded, settings, model))
}

/// Why the default (spawn a viewer) cannot work here, if it cannot.
fn viewer_unavailable() -> Option<String> {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("rerun").is_file()));
    if !on_path {
        return Some(
            "no `rerun` viewer on PATH (install it with `pip install rerun-sdk==0.36.3`)".into(),
        );
    }
    if cfg!(target_os = "linux")
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        return Some(
            "no display to open a viewer window on (DISPLAY and WAYLAND_DISPLAY are unset)".into(),
        );
    }
    None
}

fn explicit(m: &clap::ArgMatches, id: &str) -> bool {
    m.try_contains_id(id).unwrap_or(false)
        && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
}

/// The sink a run records to, and how it treats a slow consumer.
struct Sink {
    rec: rerun::RecordingStream,
    delivery: Delivery,
    /// The file being written, when there is one.
    saved: Option<PathBuf>,
    /// The live viewer, watched so that losing it follows the README's rule.
    viewer: Option<hooke::run::ViewerWatch>,
    /// Our own `.rrd` writer, where a file is recorded: it reports a full disk.
    file: Option<hooke::rrd_file::RrdFile>,
    /// `--serve`: the web viewer's server, kept up after the run until Ctrl-C.
    serving: Option<Serving>,
}

/// The served page's address (its server runs until the process ends).
struct Serving {
    page: String,
}

impl Sink {
    /// A file or a pipe: keeps every frame.
    fn stream(
        rec: rerun::RecordingStream,
        saved: Option<PathBuf>,
        file: Option<hooke::rrd_file::RrdFile>,
    ) -> Self {
        Self {
            rec,
            delivery: Delivery::Lossless,
            saved,
            viewer: None,
            file,
            serving: None,
        }
    }
}

/// A recording stream whose only sink is our `.rrd` writer at `path`.
fn file_recording(
    path: &std::path::Path,
    footer: bool,
) -> anyhow::Result<(rerun::RecordingStream, hooke::rrd_file::RrdFile)> {
    let rec = rerun::RecordingStreamBuilder::new("hooke")
        .with_blueprint(hooke::record::blueprint())
        .buffered()
        .context("starting the Rerun recording")?;
    let (sink, file) = hooke::rrd_file::create(path, footer)?;
    rec.set_sink(Box::new(sink));
    Ok((rec, file))
}

/// Where a run records, from Rerun's flags: `--stdout`; `--save FILE` alone; `--serve`; a live
/// viewer (`--connect [URL]`, or a spawned one by default), with `--save FILE` also recording
/// to that file. Where no viewer can be spawned we record to a file instead and say so, so that
/// a run is never lost.
fn open_sink(
    rerun_args: &rerun::clap::RerunArgs,
    output: &cli::OutputArgs,
    m: &clap::ArgMatches,
    scene_name: &str,
) -> anyhow::Result<Sink> {
    let blueprint = hooke::record::blueprint;
    let save = explicit(m, "save")
        .then(|| m.get_one::<PathBuf>("save").cloned())
        .flatten();
    let connect = explicit(m, "connect");
    if explicit(m, "stdout") {
        let (rec, _no_serving) = rerun_args
            .init_with_blueprint("hooke", blueprint())
            .context("starting the Rerun recording")?;
        return Ok(Sink::stream(rec, None, None));
    }
    if let Some(path) = save.as_ref().filter(|_| !connect) {
        let (rec, file) = file_recording(path, !output.no_rrd_footer)?;
        return Ok(Sink::stream(rec, save.clone(), Some(file)));
    }
    if explicit(m, "serve") {
        return serve_web_viewer(m, output);
    }
    let url = if connect {
        m.get_one::<String>("connect")
            .cloned()
            .unwrap_or_else(|| rerun::DEFAULT_CONNECT_URL.to_owned())
    } else {
        let spawned = match viewer_unavailable() {
            Some(why) => Err(why),
            None => rerun::spawn(&rerun::SpawnOptions::default())
                .map_err(|e| format!("spawning the viewer failed: {e}")),
        };
        match spawned {
            Ok(info) => {
                eprintln!("streaming to a spawned Rerun viewer");
                format!("rerun+http://127.0.0.1:{}/proxy", info.port)
            }
            Err(why) => {
                let path = PathBuf::from(format!("{scene_name}.rrd"));
                eprintln!("{why}; recording to {} instead", path.display());
                let (rec, file) = file_recording(&path, !output.no_rrd_footer)?;
                return Ok(Sink::stream(rec, Some(path), Some(file)));
            }
        }
    };
    let (link, viewer_sink) = hooke::viewer::ViewerLink::connect(&url, save.is_some())?;
    let mut sinks: Vec<Box<dyn rerun::sink::LogSink>> = vec![viewer_sink];
    let mut file = None;
    if let Some(path) = &save {
        let (sink, handle) = hooke::rrd_file::create(path, !output.no_rrd_footer)?;
        sinks.push(Box::new(sink));
        file = Some(handle);
    }
    let rec = rerun::RecordingStreamBuilder::new("hooke")
        .with_blueprint(blueprint())
        .buffered()
        .context("starting the Rerun recording")?;
    rec.set_sinks(sinks);
    Ok(Sink {
        rec,
        // A live viewer may miss frames to keep up; a file beside it must not.
        delivery: if save.is_some() {
            Delivery::Lossless
        } else {
            Delivery::DropWhenBusy
        },
        viewer: Some(hooke::run::ViewerWatch {
            link,
            file: save.clone(),
        }),
        saved: save,
        file,
        serving: None,
    })
}

/// `--serve`: the recording is served over gRPC and Rerun's web viewer over HTTP, from this
/// machine (a server with no display, typically), and stays served after the run until Ctrl-C.
fn serve_web_viewer(m: &clap::ArgMatches, output: &cli::OutputArgs) -> anyhow::Result<Sink> {
    let bind = m
        .get_one::<String>("bind")
        .cloned()
        .unwrap_or_else(|| "0.0.0.0".to_owned());
    let limit = m
        .get_one::<String>("server_memory_limit")
        .cloned()
        .unwrap_or_else(|| "25%".to_owned());
    let options = rerun::ServerOptions {
        playback_behavior: rerun::PlaybackBehavior::from_newest_first(m.get_flag("newest_first")),
        memory_limit: rerun::MemoryLimit::parse(&limit).map_err(|e| {
            anyhow::anyhow!("--server-memory-limit {limit}: {e} (use e.g. 4GB or 25%)")
        })?,
        cors_allowed_origins: Vec::new(),
    };
    let rec = rerun::RecordingStreamBuilder::new("hooke")
        .with_blueprint(hooke::record::blueprint())
        .serve_grpc_opts(&bind, output.grpc_port, options)
        .with_context(|| {
            format!(
                "serving the recording over gRPC on {bind}:{} (is the port taken? choose another with --grpc-port)",
                output.grpc_port
            )
        })?;
    let source = format!("rerun+http://localhost:{}/proxy", output.grpc_port);
    rerun::serve_web_viewer(rerun::web_viewer::WebViewerConfig {
        bind_ip: bind.clone(),
        web_port: output.web_viewer_port.into(),
        connect_to: vec![source.clone()],
        open_browser: false,
        ..Default::default()
    })
    .with_context(|| {
        format!(
            "serving the web viewer on {bind}:{} (is the port taken? choose another with --web-viewer-port)",
            output.web_viewer_port
        )
    })?
    .detach();
    let page = format!(
        "http://localhost:{}/?url={}",
        output.web_viewer_port,
        percent_encode(&source)
    );
    eprintln!(
        "serving the web viewer at {page}\n  from another machine, forward both ports first: ssh -L {w}:localhost:{w} -L {g}:localhost:{g} THIS_HOST",
        w = output.web_viewer_port,
        g = output.grpc_port
    );
    Ok(Sink {
        rec,
        delivery: Delivery::DropWhenBusy,
        saved: None,
        viewer: None,
        file: None,
        serving: Some(Serving { page }),
    })
}

/// Every byte but ASCII letters and digits as %XX (a URL query value).
fn percent_encode(s: &str) -> String {
    s.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() {
                char::from(b).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}

fn run(
    scene_arg: &str,
    solver: &cli::SolverArgs,
    (kind, adapter): (hooke::select::BackendKind, Option<String>),
    (rerun_args, output): (&rerun::clap::RerunArgs, &cli::OutputArgs),
    recording: &cli::RecordingArgs,
    m: &clap::ArgMatches,
) -> anyhow::Result<Outcome> {
    // With --stdout the recording owns standard output: messages go to stderr.
    let (loaded, settings, model) = prepare(scene_arg, solver, kind, adapter.as_deref(), |m| {
        eprintln!("{m}")
    })?;
    if let Some(w) = hooke::check::dt_warning(&model, &settings) {
        eprintln!("warning: {w}");
    }
    // The backend first: a missing GPU or a scene beyond its limits fails before any file exists.
    let backend = hooke::select::create(
        kind,
        model.clone(),
        settings.integrator,
        settings.dt_secs,
        adapter.as_deref(),
    )?;
    eprintln!(
        "hooke: '{}' with {} masses and {} springs on {}, {}, dt = {:.3e} s × {} substeps, {} frames",
        loaded.scene.name,
        model.mass_count(),
        model.spring_count(),
        backend.describe(),
        settings.integrator,
        settings.dt_secs,
        settings.substeps,
        settings.frames
    );
    for line in hooke::record::describe(&model, &recording.options()) {
        eprintln!("  recording {line}");
    }
    let sink = open_sink(rerun_args, output, m, &loaded.scene.name)?;
    if let Some(file) = &sink.file {
        let size = hooke::recording_size::estimate(
            &model,
            &settings,
            loaded.scene.view.strain_range,
            recording.options(),
        )?;
        eprintln!(
            "{}",
            hooke::recording_size::describe_for_file(&size, settings.frames, file.path())
        );
    }
    let opts = hooke::run::RunOptions {
        delivery: sink.delivery,
        progress: hooke::progress::ProgressMode::for_stderr(std::io::stderr().is_terminal()),
        realtime: recording.realtime,
        record: recording.options(),
        viewer: sink.viewer.clone(),
        file: sink.file.clone(),
    };
    // Ctrl-C or SIGTERM: the first stops stepping within a chunk of substeps (the frame in
    // progress is dropped), records every frame already produced and ends the file; a second
    // one ends the process at once.
    let cancel = Arc::new(AtomicBool::new(false));
    // After the run, with --serve, an interrupt just ends the serving.
    let serving_only = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        let serving_only = serving_only.clone();
        let installed = ctrlc::set_handler(move || {
            if serving_only.load(std::sync::atomic::Ordering::SeqCst) {
                cancel.store(true, std::sync::atomic::Ordering::SeqCst);
                return;
            }
            if cancel.swap(true, std::sync::atomic::Ordering::SeqCst) {
                eprintln!("second interrupt: exiting without finishing the recording");
                std::process::exit(130);
            }
            eprintln!(
                "interrupted: stopping now, dropping the frame in progress and saving every finished frame (again to quit at once)"
            );
        });
        if let Err(e) = installed {
            eprintln!(
                "warning: cannot catch Ctrl-C ({e}); an interrupt will end the run without flushing"
            );
        }
    }
    let result = hooke::run::run(
        &loaded,
        model,
        backend,
        &settings,
        sink.rec.clone(),
        &opts,
        cancel.clone(),
    );
    if let Some(p) = &sink.saved {
        let open = format!("open it with `rerun {}`", p.display());
        match &result {
            Ok(_) => eprintln!("saved {}; {open}", p.display()),
            // Its own message says what the file holds.
            Err(hooke::Error::WriteRecording(_)) => {}
            Err(_) => eprintln!(
                "the frames recorded before the error are in {}; {open}",
                p.display()
            ),
        }
    }
    let summary = result?;
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
    if summary.cancelled {
        return Ok(Outcome::Interrupted);
    }
    if let Some(serving) = &sink.serving {
        serving_only.store(true, std::sync::atomic::Ordering::SeqCst);
        eprintln!(
            "the recording stays served at {} until Ctrl-C",
            serving.page
        );
        while !cancel.load(std::sync::atomic::Ordering::SeqCst) {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        eprintln!("stopped serving");
    }
    Ok(Outcome::Done)
}
