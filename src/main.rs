//! The `hooke` binary: parse the command line, call the library, print errors as one message.

mod cli;

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::Context as _;
use clap::{CommandFactory as _, FromArgMatches as _};

use cli::{Cli, Command};
use hooke::scene;
use hooke::settings::Settings;
use hooke::sim::Delivery;

fn main() -> std::process::ExitCode {
    let matches = Cli::command().get_matches();
    let result = Cli::from_arg_matches(&matches)
        .map_err(anyhow::Error::from)
        .and_then(|cli| dispatch(cli, &matches));
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn dispatch(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<()> {
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
            Ok(())
        }
        Command::Check { scene, solver } => {
            let loaded = scene::load(&scene)?;
            let settings = Settings::resolve(&loaded.scene, &solver.overrides())?;
            for n in &settings.notes {
                println!("note: {n}");
            }
            let model = hooke::model::build(&loaded.scene);
            print!(
                "{}",
                hooke::check::report(&loaded.scene.name, &model, &settings)
            );
            Ok(())
        }
        Command::Run {
            scene,
            solver,
            backend,
            rerun,
        } => {
            let run_matches = matches
                .subcommand_matches("run")
                .context("parsing `run` arguments")?;
            run(&scene, &solver, backend, &rerun, run_matches)
        }
    }
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

fn run(
    scene_arg: &str,
    solver: &cli::SolverArgs,
    backend: hooke::backend::BackendKind,
    rerun_args: &rerun::clap::RerunArgs,
    m: &clap::ArgMatches,
) -> anyhow::Result<()> {
    let loaded = scene::load(scene_arg)?;
    let settings = Settings::resolve(&loaded.scene, &solver.overrides())?;
    for n in &settings.notes {
        eprintln!("note: {n}");
    }
    let model = Arc::new(hooke::model::build(&loaded.scene));
    if let Some(w) = hooke::check::dt_warning(&model, &settings) {
        eprintln!("warning: {w}");
    }

    let saving = explicit(m, "save");
    let streaming_elsewhere =
        explicit(m, "stdout") || explicit(m, "connect") || explicit(m, "serve");
    let blueprint = hooke::record::blueprint;
    // With no sink flag Rerun spawns a viewer; where none can be spawned we record to a file
    // instead and say so, so a run is never lost.
    let mut fallback: Option<PathBuf> = None;
    let (rec, _guard) = if saving || streaming_elsewhere {
        rerun_args
            .init_with_blueprint("hooke", blueprint())
            .context("starting the Rerun recording")?
    } else {
        let why = match viewer_unavailable() {
            Some(why) => Some(why),
            None => match rerun_args.init_with_blueprint("hooke", blueprint()) {
                Ok(pair) => {
                    eprintln!("streaming to a spawned Rerun viewer");
                    return finish(
                        &loaded,
                        model,
                        &settings,
                        backend,
                        pair,
                        Delivery::DropWhenBusy,
                        None,
                    );
                }
                Err(e) => Some(format!("spawning the viewer failed: {e:#}")),
            },
        };
        let path = PathBuf::from(format!("{}.rrd", loaded.scene.name));
        eprintln!(
            "{}; recording to {} instead",
            why.unwrap_or_default(),
            path.display()
        );
        let rec = rerun::RecordingStreamBuilder::new("hooke")
            .with_blueprint(blueprint())
            .save(&path)
            .with_context(|| format!("creating {}", path.display()))?;
        fallback = Some(path);
        (rec, Default::default())
    };
    let delivery = if saving || explicit(m, "stdout") || fallback.is_some() {
        Delivery::Lossless
    } else {
        Delivery::DropWhenBusy
    };
    let saved = if saving {
        m.get_one::<PathBuf>("save").cloned()
    } else {
        fallback
    };
    finish(
        &loaded,
        model,
        &settings,
        backend,
        (rec, _guard),
        delivery,
        saved.as_deref(),
    )
}

fn finish(
    loaded: &scene::LoadedScene,
    model: Arc<hooke::model::Model>,
    settings: &Settings,
    backend: hooke::backend::BackendKind,
    (rec, _guard): (rerun::RecordingStream, rerun::clap::ServeGuard),
    delivery: Delivery,
    saved: Option<&Path>,
) -> anyhow::Result<()> {
    let to_stdout = delivery == Delivery::Lossless && saved.is_none();
    let say = |s: String| {
        // With --stdout the data owns stdout; messages go to stderr either way.
        let _ = to_stdout;
        eprintln!("{s}");
    };
    say(format!(
        "hooke: '{}' with {} masses and {} springs, {}, dt = {:.3e} s × {} substeps, {} frames",
        loaded.scene.name,
        model.mass_count(),
        model.spring_count(),
        settings.integrator,
        settings.dt_secs,
        settings.substeps,
        settings.frames
    ));
    let opts = hooke::run::RunOptions {
        backend,
        delivery,
        progress: std::io::stderr().is_terminal(),
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let result = hooke::run::run(loaded, model, settings, rec, &opts, cancel);
    if let Some(p) = saved {
        let open = format!("open it with `rerun {}`", p.display());
        match &result {
            Ok(_) => say(format!("saved {}; {open}", p.display())),
            Err(_) => say(format!(
                "the frames recorded before the error are in {}; {open}",
                p.display()
            )),
        }
    }
    let summary = result?;
    say(format!(
        "done: {} frames ({:.3} s simulated) on {} in {:.2} s wall{}",
        summary.frames_recorded,
        summary.sim_time_secs,
        summary.backend,
        summary.wall_secs,
        if summary.frames_dropped > 0 {
            format!(
                ", {} frames not shown because the viewer fell behind",
                summary.frames_dropped
            )
        } else {
            String::new()
        }
    ));
    Ok(())
}
