//! One family probed: a few small built-in scenes (a strand of hair, a grid cloth falling onto a
//! sphere, a jello cube above the ground, a mesh flag), each stepped three frames on the GPU,
//! forced onto the family's paths, and on the CPU reference, and their positions compared.

use std::sync::Arc;

use super::verdict::{TOLERANCE_M, Verdict};
use crate::backend::Backend;
use crate::cpu::CpuBackend;
use crate::gpu::{GpuBackend, KernelFamily};
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::physics::Preconditioner;
use crate::scene::settings::{Overrides, Settings};
use crate::state::State;

/// The probe's scenes: masses on a line, a grid and a 3D grid, a mesh body; contacts with a
/// sphere and the ground; all small enough for every one-workgroup path.
pub const PROBE_SCENES: [&str; 4] = ["hair", "cloth", "jello", "flag"];

/// Frames each scene is stepped.
pub const PROBE_FRAMES: u32 = 3;

/// Whether `family` on the adapter `info` names is held to bit for bit on lavapipe, where the
/// tests hold it to the CPU's bits: every family but multigrid's, whose coarsest level the CPU
/// factors in f64. (Implicit Euler's and BDF2's sums are taken in lavapipe's order on the CPU,
/// `physics::SUM_LANES`; VBD's block solve adds its terms as `vbd_finish` does, in the one lane
/// a CPU adapter gives a mass.)
fn bitwise(family: KernelFamily, info: &wgpu::AdapterInfo) -> bool {
    !family.multigrid && info.driver == "llvmpipe"
}

/// The step a scene is probed at: one step a frame at 1/60 s for the schemes made for large
/// steps (where a one-workgroup solve loops the most), else the scene's own step, or half the
/// estimated stable one where that is smaller.
fn probe_step(model: &Model, settings: &Settings, integrator: Integrator) -> (Step, u32) {
    let options = settings.options;
    if integrator.scheme().assembles_blocks() {
        return (Step::new(integrator, 1.0 / 60.0).with_options(options), 1);
    }
    let stable = crate::stability::stable_dts(model)
        .into_iter()
        .find(|(i, _)| *i == integrator)
        .and_then(|(_, dt)| dt);
    let dt = match stable {
        Some(l) => settings.dt_secs.min(0.5 * l),
        None => settings.dt_secs / 20.0,
    };
    (
        Step::new(integrator, dt).with_options(options),
        settings.substeps,
    )
}

/// Step `name` on both backends as `family`; `None` where the scene cannot take the family (its
/// effects, or the adapter gives it another path) or the CPU itself fails; else the largest
/// distance of a mass from the CPU's, and whether every bit agreed (infinite where the GPU
/// failed).
fn probe_scene(name: &str, family: KernelFamily, info: &wgpu::AdapterInfo) -> Option<(f64, bool)> {
    let loaded = crate::scene::load(name).ok()?;
    let settings = Settings::resolve(&loaded.scene, &Overrides::default()).ok()?;
    let model = Arc::new(crate::model::build(&loaded.scene));
    family.integrator.supports(&model.effects).ok()?;
    let (step, substeps) = probe_step(&model, &settings, family.integrator);
    let tuning = family.tuning(&model, step);
    let gpu = GpuBackend::with_tuning(model.clone(), step, Some(&info.name), tuning);
    if gpu.as_ref().is_ok_and(|g| g.kernel_family() != family) {
        return None;
    }
    let mut cpu = CpuBackend::new(model.clone(), step);
    cpu.set_preconditioner(match family.multigrid {
        true => Preconditioner::Multigrid,
        false => Preconditioner::BlockJacobi,
    });
    let Ok(mut gpu) = gpu else {
        return Some((f64::INFINITY, false));
    };
    for _ in 0..PROBE_FRAMES {
        cpu.advance(substeps).ok()?;
        if gpu.advance(substeps).is_err() {
            return Some((f64::INFINITY, false));
        }
    }
    let c = cpu.state().ok()?;
    let Ok(g) = gpu.state() else {
        return Some((f64::INFINITY, false));
    };
    let apart = Apart::of(&c, &g);
    Some((apart.farthest_m, apart.same_bits))
}

/// How far one backend's state ends from another's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apart {
    /// The largest distance of a mass from its place in the other state (infinite where either
    /// is not finite).
    pub farthest_m: f64,
    /// Every position and velocity the same to the bit.
    pub same_bits: bool,
}

impl Apart {
    pub fn of(a: &State, b: &State) -> Self {
        let farthest_m = a.x.iter().zip(&b.x).fold(0.0, |w: f64, (p, q)| {
            let d = f64::from(p.distance(*q));
            if d.is_nan() { f64::INFINITY } else { w.max(d) }
        });
        let bits = |s: &State| {
            s.x.iter()
                .chain(&s.v)
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        Self {
            farthest_m,
            same_bits: bits(a) == bits(b),
        }
    }
}

/// Probe `family` on the adapter `info` names, on every probe scene that takes it.
pub fn probe_family(family: KernelFamily, info: &wgpu::AdapterInfo) -> Verdict {
    let bitwise = bitwise(family, info);
    let mut scenes = Vec::new();
    let mut agrees = true;
    let mut worst: Option<(&'static str, f64)> = None;
    for name in PROBE_SCENES {
        let Some((d, same_bits)) = probe_scene(name, family, info) else {
            continue;
        };
        scenes.push(name.to_owned());
        let ok = if bitwise { same_bits } else { d <= TOLERANCE_M };
        if worst.is_none_or(|(_, w)| d > w) || (!ok && agrees) {
            worst = Some((name, d));
        }
        agrees &= ok;
    }
    Verdict {
        family: family.key(),
        name: family.to_string(),
        agrees,
        bitwise,
        // JSON has no infinity: a GPU that failed a scene is as far as it gets.
        worst_m: worst.map_or(0.0, |(_, d)| d.min(f64::MAX)),
        scene: worst.map(|(n, _)| n.to_owned()),
        scenes,
    }
}
