//! How much memory a scene needs before it is built, against what the machine has: a scene that
//! cannot fit is refused with the numbers, not left to abort inside an allocation (a 8192 × 8192
//! grid, under the mass limit, asked for about 20 GB and aborted under a 4 GB cap).

use crate::laws::spring_kind::{SpringKindTag, kind_offsets};
use crate::scene::{Body, Scene};

/// Peak bytes a run takes per mass and per spring, apart from the springs: the model, the CPU
/// backend's state and work vectors, the recorder's frames. Measured as the peak resident size of
/// `hooke run … --backend cpu --frames 1 --save` on square cloths of 250 000 to 2.25 million
/// masses (dev-2c; BENCHMARKS.md, "VBD judged on the GPU, long frames in several submissions, bad input
/// bounded"): 457 MB a million masses with structural springs only, 892
/// MB with all three kinds; rounded up.
pub const BYTES_PER_MASS: u64 = 260;
/// See `BYTES_PER_MASS`: (892 − 457) MB over 4 million more springs, rounded up.
pub const BYTES_PER_SPRING: u64 = 120;
/// The GPU backend's buffers and staging on top (lavapipe holds them in host memory: a 1 000 ×
/// 1 000 cloth took 1.46 GB on the GPU backend against 0.89 GB on the CPU's), as a factor.
pub const GPU_FACTOR: f64 = 1.7;

/// What a scene needs: its masses and an upper bound on its springs, and the bytes of both.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Need {
    pub masses: u64,
    pub springs: u64,
    pub bytes: u64,
}

/// Springs a body's masses may have at most: for a grid, one per offset of each kind it has
/// that lies within its dimension; for a mesh, its edges (three per vertex bounds a triangle
/// mesh's) and, with bending, as many again.
fn springs_per_mass(b: &Body) -> u64 {
    let kinds = [
        (SpringKindTag::Structural, b.springs.structural.is_some()),
        (SpringKindTag::Shear, b.springs.shear.is_some()),
        (SpringKindTag::Bending, b.springs.bending.is_some()),
    ];
    if b.grid.is_empty() && b.surface.is_some() && b.fill == crate::scene::Fill::None {
        return 3 * kinds.iter().filter(|(_, on)| *on).count() as u64;
    }
    let dim = if b.grid.is_empty() { 3 } else { b.grid.len() };
    kinds
        .iter()
        .filter(|(_, on)| *on)
        .map(|(tag, _)| {
            kind_offsets(*tag)
                .iter()
                .filter(|o| o.iter().enumerate().all(|(a, &v)| v == 0 || a < dim))
                .count() as u64
        })
        .sum()
}

/// The scene's need on the CPU backend (`gpu`: on the GPU backend).
pub fn need(scene: &Scene, gpu: bool) -> Need {
    let (masses, springs) = scene.bodies.iter().fold((0u64, 0u64), |(m, s), b| {
        let n = b.mass_count_bound();
        (
            m.saturating_add(n),
            s.saturating_add(n.saturating_mul(springs_per_mass(b))),
        )
    });
    let cpu = masses
        .saturating_mul(BYTES_PER_MASS)
        .saturating_add(springs.saturating_mul(BYTES_PER_SPRING));
    let bytes = match gpu {
        true => (cpu as f64 * GPU_FACTOR) as u64,
        false => cpu,
    };
    Need {
        masses,
        springs,
        bytes,
    }
}

/// The memory this process may still take: the least of what the system has available
/// (`MemAvailable`), the cgroup's limit less its use, and the address-space limit (`ulimit -v`)
/// less what the process has mapped. `None` where none can be read.
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let system = meminfo
        .as_deref()
        .and_then(|m| kib_field(m, "MemAvailable:"));
    let cgroup = read_u64("/sys/fs/cgroup/memory.max")
        .zip(read_u64("/sys/fs/cgroup/memory.current"))
        .map(|(max, used)| max.saturating_sub(used));
    let status = std::fs::read_to_string("/proc/self/status").ok();
    let mapped = status.as_deref().and_then(|s| kib_field(s, "VmSize:"));
    let address_space = address_space_limit().map(|l| l.saturating_sub(mapped.unwrap_or(0)));
    [system, cgroup, address_space].into_iter().flatten().min()
}

fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

fn read_u64(path: &str) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

fn address_space_limit() -> Option<u64> {
    let mut l = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `l` is a valid rlimit for getrlimit to fill.
    let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut l) } == 0;
    (ok && l.rlim_cur != libc::RLIM_INFINITY).then_some(l.rlim_cur)
}

/// A scene too large for the memory at hand, with the numbers and what would fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "scene '{scene}' needs about {} to build and run ({masses} masses, up to {springs} springs; \
     about {BYTES_PER_MASS} B a mass and {BYTES_PER_SPRING} B a spring{}), and {} is available \
     here: {} of those masses fit; use fewer masses (a coarser grid or spacing_m), or free memory",
    gb(*bytes),
    if *gpu { ", more on the GPU backend" } else { "" },
    gb(*available),
    fitting
)]
pub struct TooLarge {
    pub scene: String,
    pub masses: u64,
    pub springs: u64,
    pub bytes: u64,
    pub available: u64,
    pub gpu: bool,
    /// About how many masses of this scene's kind would fit.
    pub fitting: u64,
}

fn gb(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Refuse `scene` where its need exceeds what is available (nothing is said where that cannot
/// be read).
pub fn check(scene: &Scene, gpu: bool) -> Result<Need, TooLarge> {
    let n = need(scene, gpu);
    match available_bytes() {
        Some(available) if n.bytes > available => Err(TooLarge {
            scene: scene.name.clone(),
            masses: n.masses,
            springs: n.springs,
            bytes: n.bytes,
            available,
            gpu,
            fitting: (n.masses as f64 * available as f64 / n.bytes.max(1) as f64) as u64,
        }),
        _ => Ok(n),
    }
}
