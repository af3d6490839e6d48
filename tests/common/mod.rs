//! Helpers shared by the test files that run the `hooke` binary and read its recordings.
//! (Each test file compiles this module on its own, so not every file uses every helper.)
#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A fresh folder of this test process.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
    d
}

/// Whether GPU tests run here: with an adapter, or fail without one where CI requires it.
pub fn gpu_available() -> bool {
    let gpu = !hooke::gpu::adapters().is_empty();
    if !gpu && std::env::var(hooke::gpu::REQUIRE_ADAPTER_ENV).is_ok_and(|v| v == "1") {
        panic!("no GPU adapter, and {}=1", hooke::gpu::REQUIRE_ADAPTER_ENV);
    }
    if !gpu {
        eprintln!("SKIPPED on the GPU: no adapter on this machine");
    }
    gpu
}

/// A recording decoded with Rerun's own decoder, which must read it to its end.
pub struct Recording {
    /// Per entity: the `frame` values it has data at.
    pub frames: BTreeMap<String, BTreeSet<i64>>,
    /// Whether the file ends with Rerun's end-of-stream footer (its chunk index).
    pub has_footer: bool,
}

impl Recording {
    /// Frames 0..n that every entity logged at frame 0 has: the frames a user can scrub whole.
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
    for msg in re_log_encoding::DecoderApp::decode_lazy(std::io::BufReader::new(file)) {
        let msg = msg.unwrap_or_else(|e| panic!("decoding {}: {e}", path.display()));
        let LogMsg::ArrowMsg(_, arrow) = msg else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap_or_else(|e| panic!("{e}"));
        let entry = frames.entry(chunk.entity_path().to_string()).or_default();
        if let Some(col) = chunk.timelines().get(&"frame".into()) {
            entry.extend(col.times_raw().iter().copied());
        }
    }
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{e}"));
    Recording {
        frames,
        has_footer: ends_with_stream_footer(&bytes),
    }
}

/// Rerun's stream footer ends a file that was finished with its index: "RRF2FOOT" and the
/// number of index entries (u32). A file cut short, or written without an index, lacks it.
fn ends_with_stream_footer(bytes: &[u8]) -> bool {
    bytes.len() >= 12 && bytes[bytes.len() - 12..].starts_with(b"RRF2FOOT")
}
