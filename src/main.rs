//! The `hooke` binary: parse the command line, call the library, print errors as one message.

mod cli;

use anyhow::Context as _;
use clap::{CommandFactory as _, FromArgMatches as _};

use cli::{Cli, Command, Outcome};
use hooke::run::prepare;

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
    let matches = with_our_help(Cli::command()).get_matches();
    #[cfg(unix)]
    if matches!(matches.subcommand_name(), Some("scenes" | "check")) {
        // SAFETY: no other thread exists yet. These commands only print: a closed standard
        // output (`hooke scenes | head`) ends them quietly, as it does a Unix filter, instead of
        // a panic in `println!`. Not for `run` or `bench`, whose connections and files must see
        // a lost peer as an error to report, never as a signal.
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }
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

/// What `hooke run --help` says of Rerun's flags where Hooke does more than Rerun's own help
/// says: `--save` beside `--connect` records to the file as well as streaming to the viewer.
fn with_our_help(cli: clap::Command) -> clap::Command {
    cli.mut_subcommand("run", |run| {
        run.mut_arg("save", |save| {
            let says = "Record to this .rrd file: alone, instead of opening a viewer; beside \
                        --connect, as well as streaming to that viewer (a viewer that goes away \
                        then leaves the run recording to the file)";
            save.help(says).long_help(says)
        })
    })
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

fn dispatch(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<Outcome> {
    match cli.command {
        Command::Scenes => cli::scenes()?,
        Command::Check {
            scene,
            solver,
            device,
        } => {
            // `check` prints to standard output, notes included.
            let planned = prepare::plan(&solver.request(&scene, &device), &mut |notice| {
                println!("{notice}")
            })?;
            cli::check(&planned, &device)?;
        }
        Command::Bench { which } => return cli::bench(which),
        Command::Sweep { which } => return cli::sweep(which),
        Command::Run {
            scene,
            solver,
            device,
            rerun,
            output,
            recording,
            compare,
        } => {
            let run_matches = matches
                .subcommand_matches("run")
                .context("parsing `run` arguments")?;
            return cli::run(&cli::RunArgs {
                scene: &scene,
                solver: &solver,
                device: &device,
                rerun: &rerun,
                output: &output,
                recording: &recording,
                compare: &compare,
                matches: run_matches,
            });
        }
    }
    Ok(Outcome::Done)
}
