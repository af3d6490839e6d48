//! Helpers shared by the test files that run the `hooke` binary and read its recordings.
//! (Not every file uses every helper.)

pub mod hard;
pub mod parity;
pub mod record;

use std::collections::{BTreeMap, BTreeSet};
use std::io::BufRead as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use rerun::log::{Chunk, LogMsg};

/// The `hooke` binary, never spawning a real viewer.
pub fn hooke_command(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_hooke"));
    c.args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY");
    c
}

pub fn hooke(args: &[&str]) -> Output {
    hooke_command(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run hooke: {e}"))
}

/// `hooke` with `args`, its address space capped at `bytes` (`ulimit -v`): an allocation that
/// grows with a bad input fails the run (and the test) instead of the machine.
pub fn hooke_within_memory(args: &[&str], bytes: u64) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {} && exec \"$0\" \"$@\"", bytes / 1024))
        .arg(env!("CARGO_BIN_EXE_hooke"))
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|e| panic!("cannot run hooke: {e}"))
}

/// `hooke run SCENE --backend cpu` followed by `rest`: the arguments of a run on the CPU backend.
pub fn cpu_run<'a>(scene: &'a str, rest: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["run", scene, "--backend", "cpu"];
    args.extend_from_slice(rest);
    args
}

/// `hooke run SCENE --backend cpu --frames FRAMES --save FILE` followed by `rest`, which must
/// succeed; returns what it printed.
pub fn save_cpu_run(scene: &str, frames: u64, file: &Path, rest: &[&str]) -> Output {
    let (frames, file) = (frames.to_string(), file.to_string_lossy());
    let mut args = cpu_run(scene, &["--frames", &frames, "--save", &file]);
    args.extend_from_slice(rest);
    let out = hooke(&args);
    assert!(out.status.success(), "{scene}: {}", text(&out.stderr));
    out
}

/// The size of a file, 0 while there is none.
pub fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map(|m| m.len()).unwrap_or(0)
}

/// The text of `examples/scenes/NAME.toml` with each `(from, to)` replaced; each `from` must be
/// there.
pub fn example_scene_with(name: &str, replacements: &[(&str, &str)]) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/scenes/{name}.toml"));
    let mut text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{e}"));
    for (from, to) in replacements {
        assert!(text.contains(from), "{name}.toml has no `{from}`");
        text = text.replace(from, to);
    }
    text
}

/// `example_scene_with`'s text written to a file of a fresh folder, named as the scene.
pub fn example_scene_file(name: &str, replacements: &[(&str, &str)]) -> PathBuf {
    let file = temp_dir(&format!("{name}-variant")).join(format!("{name}.toml"));
    std::fs::write(&file, example_scene_with(name, replacements)).unwrap_or_else(|e| panic!("{e}"));
    file
}

/// `hooke run` on the CPU backend of `example_scene_file(name, replacements)`, saved beside it,
/// with `rest` after.
pub fn run_example_variant(name: &str, replacements: &[(&str, &str)], rest: &[&str]) -> Output {
    let file = example_scene_file(name, replacements);
    let (toml, rrd) = (file.to_string_lossy(), file.with_extension("rrd"));
    let rrd = rrd.to_string_lossy();
    let mut args = vec!["run", &toml, "--backend", "cpu", "--save", &rrd];
    args.extend_from_slice(rest);
    hooke(&args)
}

/// Standard gravity (m/s²).
pub const G: f32 = 9.81;

/// Effects with standard gravity along −y, and nothing else.
pub fn gravity() -> hooke::model::Effects {
    hooke::model::Effects {
        gravity_m_per_s2: Some(glam::Vec3::new(0.0, -G, 0.0)),
        ..hooke::model::Effects::default()
    }
}

/// The value, or the test fails with the error's message.
pub fn ok<T, E: std::fmt::Display>(r: Result<T, E>) -> T {
    r.unwrap_or_else(|e| panic!("{e}"))
}

/// The model of scene text, built as a scene file is.
pub fn model_of(toml: &str) -> std::sync::Arc<hooke::model::Model> {
    let scene = ok(hooke::scene::from_toml(
        toml,
        hooke::scene::SceneOrigin::Text,
    ));
    std::sync::Arc::new(hooke::model::build(&scene))
}

/// A built-in scene's model and its own dt, prepared as `hooke run` prepares it.
pub fn scene_model(name: &str) -> (std::sync::Arc<hooke::model::Model>, f64) {
    let planned = ok(hooke::run::prepare::planned(name));
    (planned.model, planned.settings.dt_secs)
}

pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A fresh folder of this test process.
pub fn temp_dir(name: &str) -> PathBuf {
    // Tests in one binary run on parallel threads and may ask for the same name: a per-call
    // number keeps one test from removing the directory another is writing in.
    static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("hooke-test-{name}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
    d
}

/// Built-in scene `name`'s text with each `(from, to)` replaced (each must occur, so a scene
/// edited elsewhere fails loudly), written to `dir/file`; the file's path.
pub fn scene_variant(dir: &Path, name: &str, file: &str, edits: &[(&str, &str)]) -> String {
    let built_in = hooke::scene::BUILT_IN
        .iter()
        .find(|b| b.name == name)
        .unwrap_or_else(|| panic!("no built-in scene '{name}'"));
    let mut text = built_in.toml.to_owned();
    for (from, to) in edits {
        assert!(text.contains(from), "{name}.toml has no `{from}`");
        text = text.replace(from, to);
    }
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
    path.to_string_lossy().into_owned()
}

/// The backends a test runs on here: the CPU, and the GPU where `gpu_available`.
pub fn backends() -> Vec<&'static str> {
    match gpu_available() {
        true => vec!["cpu", "gpu"],
        false => vec!["cpu"],
    }
}

/// Whether GPU tests run here: with an adapter, or fail without one where CI requires it.
pub fn gpu_available() -> bool {
    let adapters = hooke::gpu::adapters();
    let gpu = !adapters.is_empty();
    let required = std::env::var(hooke::gpu::REQUIRE_ADAPTER_ENV).is_ok_and(|v| v == "1");
    if !gpu && required {
        panic!(
            "no GPU adapter, and {}=1: install mesa-vulkan-drivers (lavapipe)",
            hooke::gpu::REQUIRE_ADAPTER_ENV
        );
    }
    // Without Vulkan a machine without a GPU still offers Mesa's llvmpipe through OpenGL, whose
    // arithmetic is not the CPU's bit for bit and which binds 16 storage buffers (multigrid
    // needs 17): the parity tests would fail on what they do not test.
    if let Some(best) = adapters.first().map(|a| a.get_info())
        && required
        && best.backend == wgpu::Backend::Gl
        && best.device_type == wgpu::DeviceType::Cpu
    {
        panic!(
            "the only adapter is {} through OpenGL, and {}=1: the GPU tests run on Vulkan's \
             lavapipe; install mesa-vulkan-drivers as .ci/run does",
            best.name,
            hooke::gpu::REQUIRE_ADAPTER_ENV
        );
    }
    if !gpu {
        eprintln!(
            "SKIPPED on the GPU: no adapter on this machine (set {}=1 to make this a failure)",
            hooke::gpu::REQUIRE_ADAPTER_ENV
        );
    }
    gpu
}

/// A recording decoded with Rerun's own decoder, which must read it to its end.
pub struct Recording {
    /// Per entity: the `frame` values it has data at (none for static data).
    pub frames: BTreeMap<String, BTreeSet<i64>>,
    /// Per entity: the `sim_time` values (ns) it has data at.
    pub sim_time: BTreeMap<String, BTreeSet<i64>>,
    /// Whether the file ends with Rerun's end-of-stream footer (its chunk index).
    pub has_footer: bool,
}

impl Recording {
    /// Frames 0..n that every entity logged at frame 0 has: the frames a user can scrub whole.
    /// The frames `entity` has data at, in order (none when it is not in the recording).
    pub fn frames_of(&self, entity: &str) -> Vec<i64> {
        self.frames
            .get(entity)
            .map(|f| f.iter().copied().collect())
            .unwrap_or_default()
    }

    pub fn complete_frames(&self) -> i64 {
        let mut n = 0;
        while self
            .frames
            .values()
            .filter(|f| f.contains(&0))
            .all(|f| f.contains(&n))
        {
            n += 1;
        }
        n
    }
}

pub fn read_rrd(path: &Path) -> Recording {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut frames: BTreeMap<String, BTreeSet<i64>> = BTreeMap::new();
    let mut sim_time: BTreeMap<String, BTreeSet<i64>> = BTreeMap::new();
    for msg in re_log_encoding::DecoderApp::decode_lazy(std::io::BufReader::new(file)) {
        let msg = msg.unwrap_or_else(|e| panic!("decoding {}: {e}", path.display()));
        let LogMsg::ArrowMsg(_, arrow) = msg else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap_or_else(|e| panic!("{e}"));
        let entity = chunk.entity_path().to_string();
        for (name, timeline) in [("frame", &mut frames), ("sim_time", &mut sim_time)] {
            let entry = timeline.entry(entity.clone()).or_default();
            if let Some(col) = chunk.timelines().get(&name.into()) {
                entry.extend(col.times_raw().iter().copied());
            }
        }
    }
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{e}"));
    Recording {
        frames,
        sim_time,
        has_footer: ends_with_stream_footer(&bytes),
    }
}

/// The `rerun` command (the viewer's CLI, `pip install rerun-sdk==0.36.3` as the README says),
/// or the one `HOOKE_RERUN` names.
pub fn rerun_cli() -> PathBuf {
    if let Some(p) = std::env::var_os("HOOKE_RERUN") {
        return PathBuf::from(p);
    }
    let on_path = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("rerun"))
            .find(|p| p.is_file())
    });
    on_path.unwrap_or_else(|| {
        panic!(
            "no `rerun` command on PATH: the tests check recordings with Rerun's own verifier; \
             install it with `pip install rerun-sdk==0.36.3` (README), or name it in HOOKE_RERUN"
        )
    })
}

/// A recording a run made from bad input, checked as the README promises: `rerun rrd verify`
/// (Rerun's own reader, its footer and index included) passes, and no value in it is NaN or
/// infinite. Returns it decoded.
pub fn verified_rrd(path: &Path) -> Recording {
    verify_rrd(path, true)
}

/// [`verified_rrd`] for a file that ends without its index by design: the disk filled, or a
/// second Ctrl-C left at once. Every frame in it must still read.
pub fn verified_rrd_without_index(path: &Path) -> Recording {
    verify_rrd(path, false)
}

fn verify_rrd(path: &Path, footers: bool) -> Recording {
    let out = Command::new(rerun_cli())
        .args(["rrd", "verify", "--check-footers", &footers.to_string()])
        .arg(path)
        .output()
        .unwrap_or_else(|e| panic!("running rerun rrd verify: {e}"));
    assert!(
        out.status.success(),
        "rerun rrd verify {}: {}{}",
        path.display(),
        text(&out.stdout),
        text(&out.stderr)
    );
    let bad = record::non_finite_components(path);
    assert!(
        bad.is_empty(),
        "{} holds NaN or infinity in {bad:?}",
        path.display()
    );
    read_rrd(path)
}

/// Rerun's stream footer ends a file that was finished with its index: "RRF2FOOT" and the
/// number of index entries (u32). A file cut short, or written without an index, lacks it.
fn ends_with_stream_footer(bytes: &[u8]) -> bool {
    bytes.len() >= 12 && bytes[bytes.len() - 12..].starts_with(b"RRF2FOOT")
}

/// A free TCP port on loopback (free when asked; tests take it at once).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap_or_else(|e| panic!("no free port: {e}"))
}

/// Wait up to a minute for `ready`.
pub fn wait_for(mut ready: impl FnMut() -> bool, what: &str) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while !ready() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `hooke` running, its standard error read line by line as it comes.
pub struct Running {
    pub child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl Running {
    pub fn start(args: &[&str]) -> Self {
        let mut child = hooke_command(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run hooke: {e}"));
        let (tx, lines) = mpsc::channel();
        let err = child.stderr.take().unwrap_or_else(|| panic!("no stderr"));
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Self {
            child,
            lines,
            seen: Vec::new(),
        }
    }

    /// Wait for a line of standard error containing `needle`.
    pub fn expect(&mut self, needle: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(60);
        loop {
            if let Some(l) = self.seen.iter().find(|l| l.contains(needle)) {
                return l.clone();
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) => self.seen.push(l),
                Err(_) => panic!(
                    "no line with `{needle}` from hooke; it said:\n{}",
                    self.seen.join("\n")
                ),
            }
        }
    }

    pub fn signal(&self, signal: &str) {
        let sent = Command::new("kill")
            .args([signal, &self.child.id().to_string()])
            .status()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(sent.success());
    }

    /// Wait for the exit; returns its code and everything it said.
    pub fn finish(mut self) -> (Option<i32>, String) {
        let deadline = Instant::now() + Duration::from_secs(60);
        let status = loop {
            if let Some(s) = self.child.try_wait().unwrap_or_else(|e| panic!("{e}")) {
                break s;
            }
            assert!(
                Instant::now() < deadline,
                "hooke did not stop; it said:\n{}",
                self.seen.join("\n")
            );
            std::thread::sleep(Duration::from_millis(20));
        };
        // The reader thread ends with the pipe.
        while let Ok(l) = self.lines.recv_timeout(Duration::from_secs(5)) {
            self.seen.push(l);
        }
        (status.code(), self.seen.join("\n"))
    }
}
