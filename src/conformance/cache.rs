//! Where the probe's verdicts are kept: one JSON file in the user's cache directory
//! (`$HOOKE_CACHE_DIR`, else `$XDG_CACHE_HOME/hooke`, else `~/.cache/hooke`), verdicts listed
//! under a key naming the adapter, its driver and version, and this binary. A file that cannot
//! be read or written costs only a probe on the next run.

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::verdict::Verdict;
use crate::gpu::KernelFamily;

/// The verdicts of this adapter and binary, and the file's others (kept as they were).
#[derive(Debug)]
pub struct Cache {
    key: String,
    all: BTreeMap<String, Vec<Verdict>>,
}

/// The cache file, where the environment names a place for it.
pub fn cache_path() -> Option<PathBuf> {
    let var = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    let dir = var("HOOKE_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("hooke")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("hooke")))?;
    Some(dir.join("conformance.json"))
}

/// This binary, as its file's size and time: a rebuilt binary (new kernels, new CPU code) is
/// probed anew.
fn binary() -> String {
    let exe = std::env::current_exe().and_then(std::fs::metadata);
    let stamp = exe.ok().map(|m| {
        let at = m
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        format!("{} bytes, {at}", m.len())
    });
    format!(
        "hooke {} ({})",
        env!("CARGO_PKG_VERSION"),
        stamp.unwrap_or_default()
    )
}

impl Cache {
    /// The verdicts kept for the adapter `info` names and this binary.
    pub fn load(info: &wgpu::AdapterInfo) -> Self {
        let key = format!(
            "{} | {:?} | {} {} | {}",
            info.name,
            info.backend,
            info.driver,
            info.driver_info,
            binary()
        );
        let all = cache_path()
            .and_then(|p| std::fs::read_to_string(p).ok())
            .and_then(|text| serde_json::from_str(&text).ok())
            .unwrap_or_default();
        Self { key, all }
    }

    pub fn get(&self, family: &KernelFamily) -> Option<&Verdict> {
        let key = family.key();
        self.all.get(&self.key)?.iter().find(|v| v.family == key)
    }

    /// Keep `verdict` in place of any earlier one of its family.
    pub fn put(&mut self, verdict: Verdict) {
        let list = self.all.entry(self.key.clone()).or_default();
        list.retain(|v| v.family != verdict.family);
        list.push(verdict);
    }

    /// Write the file (a temporary file renamed over it: runs in parallel never read half of
    /// one). A failure is not the run's: the next run probes again.
    pub fn save(&self) {
        let Some(path) = cache_path() else {
            return;
        };
        let Ok(text) = serde_json::to_string_pretty(&self.all) else {
            return;
        };
        let tmp = path.with_extension(format!("json.{}", std::process::id()));
        let written = path
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| std::fs::write(&tmp, text))
            .and_then(|()| std::fs::rename(&tmp, &path));
        if written.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
    }
}
