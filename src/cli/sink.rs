//! Where a run records, from Rerun's own flags: standard output, a file, a served web viewer, or
//! a live viewer (connected to or spawned, with a file beside it on request), and how each treats
//! a slow consumer. Rerun's flags are read here, where the command line is; the sinks themselves
//! (our `.rrd` writer, the watched viewer link) are the library's.

use std::path::PathBuf;

use anyhow::Context as _;

use hooke::run::sim::Delivery;

use super::args::OutputArgs;

/// Why the default (spawn a viewer) cannot work here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ViewerUnavailable {
    NotOnPath,
    NoDisplay,
}

impl std::fmt::Display for ViewerUnavailable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ViewerUnavailable::NotOnPath => {
                "no `rerun` viewer on PATH (install it with `pip install rerun-sdk==0.36.3`)"
            }
            ViewerUnavailable::NoDisplay => {
                "no display to open a viewer window on (DISPLAY and WAYLAND_DISPLAY are unset)"
            }
        })
    }
}

/// Why the default (spawn a viewer) cannot work here, if it cannot.
fn viewer_unavailable() -> Option<ViewerUnavailable> {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("rerun").is_file()));
    if !on_path {
        return Some(ViewerUnavailable::NotOnPath);
    }
    if cfg!(target_os = "linux")
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        return Some(ViewerUnavailable::NoDisplay);
    }
    None
}

/// Whether the command line gave `id` itself (not its default).
pub fn explicit(m: &clap::ArgMatches, id: &str) -> bool {
    m.try_contains_id(id).unwrap_or(false)
        && m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
}

/// The sink a run records to, and how it treats a slow consumer.
pub struct Sink {
    pub rec: rerun::RecordingStream,
    pub delivery: Delivery,
    /// The file being written, when there is one.
    pub saved: Option<PathBuf>,
    /// The live viewer, watched so that losing it follows docs/guide/running.md's rule.
    pub viewer: Option<hooke::run::ViewerWatch>,
    /// Our own `.rrd` writer, where a file is recorded: it reports a full disk.
    pub file: Option<hooke::record::rrd_file::RrdFile>,
    /// `--serve`: the web viewer's server, kept up after the run until Ctrl-C.
    pub serving: Option<Serving>,
}

/// The served page's address (its server runs until the process ends).
pub struct Serving {
    pub page: String,
}

impl Sink {
    /// A file or a pipe: keeps every frame.
    fn stream(
        rec: rerun::RecordingStream,
        saved: Option<PathBuf>,
        file: Option<hooke::record::rrd_file::RrdFile>,
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

/// Every run's recording: Hooke's application id (the recorder sends its blueprint with the
/// scene's static entities, framed on its bodies: `record::send_blueprint`).
fn builder() -> rerun::RecordingStreamBuilder {
    rerun::RecordingStreamBuilder::new(hooke::record::APPLICATION_ID)
}

/// A recording stream whose sinks are set afterwards.
fn buffered() -> anyhow::Result<rerun::RecordingStream> {
    let rec = builder()
        .buffered()
        .context("starting the Rerun recording")?;
    Ok(rec)
}

/// A scene's name as a file name in the working folder: characters other than letters, digits,
/// `-`, `_` and `.` become `_`, and leading dots go (a scene named "../../x" must not write
/// outside the folder, nor make a hidden file).
pub fn file_stem_of(name: &str) -> String {
    let safe: String = name
        .chars()
        .map(
            |c| match c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                true => c,
                false => '_',
            },
        )
        .collect();
    let safe = safe.trim_start_matches('.');
    match safe.is_empty() {
        true => "recording".to_owned(),
        false => safe.to_owned(),
    }
}

/// A recording stream whose only sink is our `.rrd` writer at `path`.
fn file_recording(
    path: &std::path::Path,
    footer: bool,
) -> anyhow::Result<(rerun::RecordingStream, hooke::record::rrd_file::RrdFile)> {
    let rec = buffered()?;
    let (sink, file) = hooke::record::rrd_file::create(path, footer)?;
    rec.set_sink(Box::new(sink));
    Ok((rec, file))
}

/// Where a run records, from Rerun's flags: `--stdout`; `--save FILE` alone; `--serve`; a live
/// viewer (`--connect [URL]`, or a spawned one by default), with `--save FILE` also recording
/// to that file. Where no viewer can be spawned we record to a file instead and say so, so that
/// a run is never lost.
pub fn open_sink(
    rerun_args: &rerun::clap::RerunArgs,
    output: &OutputArgs,
    m: &clap::ArgMatches,
    scene_name: &str,
) -> anyhow::Result<Sink> {
    let save = explicit(m, "save")
        .then(|| m.get_one::<PathBuf>("save").cloned())
        .flatten();
    let connect = explicit(m, "connect");
    if let Some(path) = &save {
        let other = [
            ("stdout", "`--stdout > FILE` saves it too"),
            (
                "serve",
                "the web viewer serves it from memory: run with --save alone and open the file, or with --serve alone",
            ),
        ]
        .into_iter()
        .find(|(flag, _)| explicit(m, flag));
        if let Some((flag, instead)) = other {
            anyhow::bail!(
                "--save {} and --{flag} both ask for the recording, and Hooke does not do both: {instead}",
                path.display()
            );
        }
    }
    if explicit(m, "stdout") {
        let (rec, _no_serving) = rerun_args
            .init(hooke::record::APPLICATION_ID)
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
            Some(why) => Err(why.to_string()),
            None => rerun::spawn(&rerun::SpawnOptions::default())
                .map_err(|e| format!("spawning the viewer failed: {e}")),
        };
        match spawned {
            Ok(info) => {
                eprintln!("streaming to a spawned Rerun viewer");
                format!("rerun+http://127.0.0.1:{}/proxy", info.port)
            }
            Err(why) => {
                let path = PathBuf::from(format!("{}.rrd", file_stem_of(scene_name)));
                eprintln!("{why}; recording to {} instead", path.display());
                let (rec, file) = file_recording(&path, !output.no_rrd_footer)?;
                return Ok(Sink::stream(rec, Some(path), Some(file)));
            }
        }
    };
    let (link, viewer_sink) = hooke::record::viewer::ViewerLink::connect(&url, save.is_some())?;
    let mut sinks: Vec<Box<dyn rerun::sink::LogSink>> = vec![viewer_sink];
    let mut file = None;
    if let Some(path) = &save {
        let (sink, handle) = hooke::record::rrd_file::create(path, !output.no_rrd_footer)?;
        sinks.push(Box::new(sink));
        file = Some(handle);
    }
    let rec = buffered()?;
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
fn serve_web_viewer(m: &clap::ArgMatches, output: &OutputArgs) -> anyhow::Result<Sink> {
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
    let rec = builder()
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

#[cfg(test)]
mod tests {
    use super::file_stem_of;

    #[test]
    fn a_scene_name_becomes_a_file_name_in_the_working_folder() {
        assert_eq!(file_stem_of("cloth"), "cloth");
        assert_eq!(file_stem_of("../../pwned"), "_.._pwned");
        assert_eq!(file_stem_of(".hidden"), "hidden");
        assert_eq!(file_stem_of("a b/c"), "a_b_c");
        assert_eq!(file_stem_of("..."), "recording");
        assert_eq!(file_stem_of(""), "recording");
    }
}
