//! The conformance probe: whether this adapter computes what the CPU reference computes, kernel
//! family by kernel family (`gpu::KernelFamily`: the integrator and the path its steps take).
//! A family is stepped on a few small built-in scenes (`probe`) on the GPU and on the CPU, and
//! the states compared: bit for bit where the adapter is lavapipe and the family is one the tests
//! hold to the CPU's bits there (every family but multigrid's), within `TOLERANCE_M` everywhere
//! else. The verdict is kept per adapter,
//! driver, binary and family in a small file in the user's cache directory (`cache`), so a run
//! probes only the families it uses that have no verdict yet, and later runs pay nothing. A
//! family that disagrees is refused with one message (`Disagrees`); `--no-verify` skips the
//! probe, `hooke check --verify` runs it whatever the cache holds.
//!
//! It sits with `select`, above both backends: it steps both.

mod cache;
mod probe;
mod twins;
mod verdict;

pub use cache::{Cache, cache_path};
pub use probe::{Apart, PROBE_FRAMES, PROBE_SCENES, probe_family};
pub use verdict::{TOLERANCE_M, Verdict};

use crate::gpu::GpuBackend;

/// When a run probes its adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verify {
    /// The families with no verdict in the cache (a run's default).
    #[default]
    Unseen,
    /// Every family the run uses, whatever the cache holds (`hooke check --verify`).
    Always,
    /// None (`--no-verify`).
    Never,
}

/// A kernel family this adapter gets wrong: the run is refused.
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "{adapter} (driver {driver}) does not compute what the CPU reference computes for {verdict}. \
     Run with --backend cpu, or update the GPU driver; --no-verify runs it anyway (the verdict \
     is kept in {cache})"
)]
pub struct Disagrees {
    pub adapter: String,
    pub driver: String,
    pub verdict: Verdict,
    pub cache: String,
}

/// The verdict on `gpu`'s family on its adapter: from the cache where `verify` allows, else
/// probed now (and kept). `Err` where the family disagrees.
pub fn verify(gpu: &GpuBackend, verify: Verify) -> Result<Option<Verdict>, Box<Disagrees>> {
    if verify == Verify::Never {
        return Ok(None);
    }
    let info = gpu.adapter_info().clone();
    let family = gpu.kernel_family();
    let mut cache = Cache::load(&info);
    let verdict = match cache.get(&family).filter(|_| verify == Verify::Unseen) {
        Some(v) => v.clone(),
        None => {
            let v = probe_family(family, &info);
            cache.put(v.clone());
            cache.save();
            v
        }
    };
    if verdict.agrees {
        return Ok(Some(verdict));
    }
    Err(Box::new(Disagrees {
        adapter: info.name.clone(),
        driver: format!("{} {}", info.driver, info.driver_info),
        verdict,
        cache: cache_path().map_or_else(|| "no file".to_owned(), |p| p.display().to_string()),
    }))
}
