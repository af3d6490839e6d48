//! Live viewing and remote use, on loopback only: a viewer that goes away mid-run (docs/guide/running.md's
//! rule: with `--save FILE` the run finishes into the file, without it the run stops cleanly),
//! a viewer that is never there, and `--serve` hosting the web viewer for a machine with no
//! display.
//!
//! The "viewer" here is a stand-in: this test binary re-run as a child process that serves
//! Rerun's gRPC endpoint (what a viewer listens on) and is killed to make it go away.

use hooke::integrator::Step;
use std::io::{Read as _, Write as _};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use crate::common::{Running, cpu_run, file_size, free_port, read_rrd, wait_for};

const STUB_PORT_ENV: &str = "HOOKE_TEST_STUB_VIEWER_PORT";

/// Not a test: the stand-in viewer, run by the tests below as a child process of this binary.
#[test]
#[ignore = "a helper process for the tests of this file, started by them"]
fn stub_viewer_process() {
    let Ok(port) = std::env::var(STUB_PORT_ENV) else {
        return;
    };
    let port: u16 = port.parse().unwrap_or_else(|e| panic!("{e}"));
    let _server = rerun::RecordingStreamBuilder::new("stub-viewer")
        .serve_grpc_opts("127.0.0.1", port, rerun::ServerOptions::default())
        .unwrap_or_else(|e| panic!("stub viewer: {e}"));
    println!("stub viewer listening");
    loop {
        std::thread::sleep(Duration::from_secs(1));
    }
}

fn start_stub_viewer(port: u16) -> Child {
    let exe = std::env::current_exe().unwrap_or_else(|e| panic!("{e}"));
    // The helper's name as the harness knows it: its module path within the suite.
    let helper = match module_path!().split_once("::") {
        Some((_, module)) => format!("{module}::stub_viewer_process"),
        None => String::from("stub_viewer_process"),
    };
    let child = Command::new(exe)
        .args(["--exact", &helper, "--ignored", "--nocapture"])
        .env(STUB_PORT_ENV, port.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("{e}"));
    wait_for(
        || std::net::TcpStream::connect(("127.0.0.1", port)).is_ok(),
        "the stub viewer to listen",
    );
    child
}

/// With `--save FILE` beside `--connect`, a viewer that goes away is reported once and the run
/// goes on into the file, which keeps every frame from the first.
#[test]
fn a_viewer_that_goes_away_leaves_the_run_recording_to_the_named_file() {
    let port = free_port();
    let mut viewer = start_stub_viewer(port);
    let dir = std::env::temp_dir().join(format!("hooke-test-viewer-gone-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let path = dir.join("hair.rrd");
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let mut run = Running::start(&cpu_run(
        "hair",
        &[
            "--duration",
            "3600",
            "--connect",
            &url,
            "--save",
            &path.to_string_lossy(),
        ],
    ));
    // The run writes the partial file, which takes the file's name when the run ends.
    let partial = dir.join("hair.rrd.partial");
    wait_for(|| file_size(&partial) > 200_000, "frames in the file");
    viewer.kill().unwrap_or_else(|e| panic!("{e}"));
    let _ = viewer.wait();
    let said = run.expect("went away");
    assert!(
        said.contains(&url) && said.contains("recording the rest of the run to"),
        "{said}"
    );
    // Still recording: the file keeps growing after the viewer left.
    let size = file_size(&partial);
    wait_for(
        || file_size(&partial) > size + 100_000,
        "the file to grow after the viewer went away",
    );
    run.signal("-INT");
    let (code, err) = run.finish();
    assert_eq!(code, Some(130), "{err}");
    assert_eq!(
        err.matches("went away").count(),
        1,
        "said more than once:\n{err}"
    );
    let frames = read_rrd(&path).frames_of("/world/strand_0/masses");
    let n = frames.len() as i64;
    assert!(n > 10, "only {n} frames");
    assert_eq!(frames, (0..n).collect::<Vec<_>>(), "frames missing");
    let _ = std::fs::remove_dir_all(dir);
}

/// With no file named, a viewer that goes away stops the run cleanly with one message saying
/// how to keep a run whatever the viewer does.
#[test]
fn a_viewer_that_goes_away_stops_a_run_that_records_nowhere_else() {
    let port = free_port();
    let mut viewer = start_stub_viewer(port);
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let mut run = Running::start(&cpu_run("hair", &["--duration", "3600", "--connect", &url]));
    run.expect("hooke: 'hair'");
    std::thread::sleep(Duration::from_secs(2));
    viewer.kill().unwrap_or_else(|e| panic!("{e}"));
    let _ = viewer.wait();
    let (code, err) = run.finish();
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&format!("the viewer at {url} went away at frame"))
            && err.contains("--save FILE"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// `--connect` to an address where no viewer listens ends with a clear message, never a hang.
#[test]
fn connecting_to_no_viewer_is_a_clear_error() {
    let port = free_port();
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    let run = Running::start(&cpu_run("hair", &["--duration", "3600", "--connect", &url]));
    let (code, err) = run.finish();
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&format!("the viewer at {url} went away"))
            && err.contains("no viewer accepted the connection"),
        "{err}"
    );
}

fn http_get(port: u16, path: &str) -> (String, Vec<u8>) {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap_or_else(|e| panic!("{e}"));
    s.set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap_or_else(|e| panic!("{e}"));
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut bytes = Vec::new();
    s.read_to_end(&mut bytes).unwrap_or_else(|e| panic!("{e}"));
    let split = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or(bytes.len());
    let head = String::from_utf8_lossy(&bytes[..split]).into_owned();
    let body = &bytes[(split + 4).min(bytes.len())..];
    let chunked = head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked");
    (
        head,
        if chunked {
            dechunk(body)
        } else {
            body.to_vec()
        },
    )
}

/// The body of a chunked HTTP/1.1 response: hex size, CRLF, data, CRLF, … until size 0.
fn dechunk(mut rest: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line_end = rest
            .windows(2)
            .position(|w| w == b"\r\n")
            .unwrap_or_else(|| panic!("bad chunk"));
        let size_text = String::from_utf8_lossy(&rest[..line_end]).into_owned();
        let size = usize::from_str_radix(size_text.split(';').next().unwrap_or("").trim(), 16)
            .unwrap_or_else(|e| panic!("chunk size `{size_text}`: {e}"));
        rest = &rest[line_end + 2..];
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&rest[..size]);
        rest = &rest[size + 2..];
    }
}

/// `--serve` on a machine with no display: the web viewer's page and its Wasm are served over
/// HTTP, the recording over gRPC, both on loopback here; the run ends and keeps serving until
/// Ctrl-C, which then ends it cleanly.
#[test]
fn serve_hosts_the_web_viewer_and_the_recording() {
    let (grpc, web) = (free_port(), free_port());
    let mut run = Running::start(&cpu_run(
        "hair",
        &[
            "--frames",
            "30",
            "--serve",
            "--bind",
            "127.0.0.1",
            "--grpc-port",
            &grpc.to_string(),
            "--web-viewer-port",
            &web.to_string(),
        ],
    ));
    let page = run.expect("serving the web viewer at");
    assert!(
        page.contains(&format!(
            "http://localhost:{web}/?url=rerun%2Bhttp%3A%2F%2Flocalhost%3A{grpc}%2Fproxy"
        )),
        "{page}"
    );
    run.expect("stays served at");
    let (head, body) = http_get(web, "/");
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    let html = String::from_utf8_lossy(&body);
    assert!(html.contains("re_viewer"), "not the viewer's page:\n{html}");
    let (head, wasm) = http_get(web, "/re_viewer_bg.wasm");
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    assert_eq!(wasm.get(..4), Some(&b"\0asm"[..]), "not WebAssembly");
    assert!(
        std::net::TcpStream::connect(("127.0.0.1", grpc)).is_ok(),
        "nothing on the gRPC port"
    );
    run.signal("-INT");
    let (code, err) = run.finish();
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("stopped serving"), "{err}");
}

/// A viewer slower than the simulation never stalls it: frames it cannot take are dropped for
/// display and counted, every frame is accounted for, and a file (lossless) gets every frame.
#[test]
fn a_slow_viewer_never_stalls_the_simulation_and_a_file_drops_nothing() {
    use hooke::run::sim::{Delivery, simulate};
    let loaded = hooke::scene::load("hair").unwrap_or_else(|e| panic!("{e}"));
    let model = std::sync::Arc::new(hooke::model::build(&loaded.scene));
    let frames = 200u64;
    for delivery in [Delivery::DropWhenBusy, Delivery::Lossless] {
        let mut be = hooke::cpu::CpuBackend::new(
            model.clone(),
            Step::new(hooke::integrator::Integrator::SemiImplicit, 1e-3),
        );
        let (tx, rx) = crossbeam_channel::bounded::<hooke::state::Snapshot>(2);
        // The "viewer": takes a frame every 5 ms, far slower than the simulation.
        let viewer = std::thread::spawn(move || {
            let mut got = Vec::new();
            for s in rx.iter() {
                got.push(s.frame);
                std::thread::sleep(Duration::from_millis(5));
            }
            got
        });
        let cancel = std::sync::atomic::AtomicBool::new(false);
        let out = simulate(&mut be, frames, 5, &tx, delivery, &cancel, None);
        drop(tx);
        let got = viewer.join().unwrap_or_else(|_| panic!("viewer thread"));
        assert!(out.failed.is_none() && !out.cancelled);
        assert_eq!(out.frames_sent, got.len() as u64);
        assert_eq!(
            out.frames_sent + out.frames_dropped,
            frames + 1,
            "{delivery:?}"
        );
        assert!(
            got.windows(2).all(|w| w[0] < w[1]),
            "{delivery:?}: out of order"
        );
        match delivery {
            Delivery::DropWhenBusy => assert!(
                out.frames_dropped > frames / 2,
                "the slow viewer should have missed most frames, missed {}",
                out.frames_dropped
            ),
            Delivery::Lossless => {
                assert_eq!(out.frames_dropped, 0);
                assert_eq!(got, (0..=frames).collect::<Vec<_>>());
            }
        }
    }
}
