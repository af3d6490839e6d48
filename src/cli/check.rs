//! `hooke check`: the model a scene builds, and whether the chosen step is stable.

use std::fmt::Write as _;

use hooke::model::{BodyShape, MeshVertices, Model, SpringKindTag};
use hooke::run::prepare::Planned;
use hooke::run::select::BackendKind;
use hooke::scene::settings::Settings;
use hooke::stability::{Modes, dt_warning, stable_steps, sweep_warning};

use super::args::DeviceArgs;
use super::check_effects::effects;

/// `hooke check`: the model, its stable steps, the recording's size and the device, on standard
/// output.
pub fn check(planned: &Planned, device: &DeviceArgs) -> anyhow::Result<()> {
    let Planned {
        loaded,
        settings,
        model,
    } = planned;
    print!("{}", report(&loaded.scene.name, model, settings));
    if let Some(c) = &loaded.scene.compare {
        println!(
            "compare: `hooke run` records this scene under {}, {} (each entry checked as the run starts; --compare overrides)",
            c.entries.join(", "),
            if c.overlay {
                "overlaid"
            } else {
                "side by side"
            }
        );
    }
    let record = hooke::record::RecordOptions::default().for_scene(&loaded.scene);
    let size = hooke::run::recording_size::estimate(model, settings, record)?;
    println!(
        "recording (estimated from sample frames, default --springs and --surface): about {} per frame, {} for all {} frames",
        hooke::record::rrd_file::human_bytes(size.bytes_per_frame),
        hooke::record::rrd_file::human_bytes(size.total(settings.frames)),
        settings.frames + 1
    );
    for line in hooke::record::describe(model, &record) {
        println!("  recording {line}");
    }
    match device.backend {
        BackendKind::Cpu => println!("backend: cpu ({} threads)", rayon::current_num_threads()),
        BackendKind::Gpu => {
            match hooke::gpu::adapter_report(device.adapter.as_deref(), model, settings.step()) {
                Ok(line) => println!("{line}"),
                Err(e) => println!("warning: {e}"),
            }
            conformance(model, settings, device)?;
        }
    }
    Ok(())
}

/// The conformance probe's verdict on the kernels a run of this scene steps with: probed now
/// with `--verify` (an error where the adapter disagrees with the CPU), else as kept.
fn conformance(
    model: &std::sync::Arc<Model>,
    settings: &Settings,
    device: &DeviceArgs,
) -> anyhow::Result<()> {
    use hooke::conformance::{Cache, Verify, verify};
    let gpu = match hooke::gpu::GpuBackend::new(
        model.clone(),
        settings.step(),
        device.adapter.as_deref(),
    ) {
        Ok(gpu) => gpu,
        Err(e) => {
            println!("warning: {e}");
            return Ok(());
        }
    };
    // The report above lists a discrete GPU's passes; a driver that caps loops steps otherwise.
    let here = hooke::gpu::adapter_step_passes(&gpu, model, settings.integrator);
    if here != hooke::gpu::step_report(model, settings.step()).passes {
        println!("GPU step passes on this adapter: {}", here.join(" → "));
    }
    let family = gpu.kernel_family();
    if device.no_verify {
        println!("conformance: {family} not probed (--no-verify)");
    } else if device.verify {
        let verdict = verify(&gpu, Verify::Always)?;
        if let Some(v) = verdict {
            println!("conformance (probed now against the CPU reference): {v}");
        }
    } else {
        match Cache::load(gpu.adapter_info()).get(&family) {
            Some(v) => println!("conformance (kept from an earlier probe): {v}"),
            None => println!(
                "conformance: {family} not probed on this adapter yet (a run probes it first; \
                 `hooke check --verify` probes it now)"
            ),
        }
    }
    Ok(())
}

pub fn report(name: &str, model: &Model, settings: &Settings) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "scene '{name}'");
    masses_and_springs(&mut s, model);
    effects(&mut s, model);
    solver(&mut s, model, settings);
    let _ = writeln!(s, "{}", hooke::gpu::step_report(model, settings.step()));
    preconditioner(&mut s, model, settings);
    if let Some(w) = dt_warning(model, settings) {
        let _ = writeln!(s, "warning: {w}");
    }
    if let Some(w) = sweep_warning(model, settings) {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}

/// Masses, springs of each kind, and each body's grid.
fn masses_and_springs(s: &mut String, model: &Model) {
    let _ = writeln!(
        s,
        "  masses: {} ({} pinned), springs: {}",
        model.mass_count(),
        model.pinned_count(),
        model.spring_count()
    );
    for kind in [
        SpringKindTag::Structural,
        SpringKindTag::Shear,
        SpringKindTag::Bending,
        SpringKindTag::Custom,
    ] {
        let n = model.springs_of_kind(kind);
        if n > 0 {
            let _ = writeln!(s, "    {:<10} {n}", kind.name());
        }
    }
    for b in &model.bodies {
        let layout = match &b.shape {
            BodyShape::Grid(g) => {
                let grid: Vec<String> = g.iter().map(u32::to_string).collect();
                format!("grid {} ({}D)", grid.join("×"), g.len())
            }
            BodyShape::Mesh(m) => {
                let what = match (&m.vertices, m.closed) {
                    (MeshVertices::Embedded(_), _) => "filled with a lattice",
                    (MeshVertices::Masses(_), true) => "a closed shell",
                    (MeshVertices::Masses(_), false) => "cloth",
                };
                format!("mesh {} ({} triangles, {what})", m.file, m.triangles.len())
            }
        };
        let _ = writeln!(
            s,
            "  body '{}': {layout}, {} masses, {} springs",
            b.name,
            b.masses.len(),
            b.springs.len()
        );
        pinned(s, model, b.masses.clone());
    }
}

/// Where a body's pins landed, the first few by position (a mesh's vertex numbers
/// follow the order its faces use them, so `pins = [0, 10]` may not be the corners one meant).
fn pinned(s: &mut String, model: &Model, masses: std::ops::Range<u32>) {
    const SHOWN: usize = 6;
    let at: Vec<String> = masses
        .map(|i| i as usize)
        .filter(|&i| model.inv_mass[i] == 0.0)
        .map(|i| {
            let p = model.initial.x[i];
            format!("[{:.3}, {:.3}, {:.3}]", p.x, p.y, p.z)
        })
        .collect();
    if at.is_empty() {
        return;
    }
    let more = match at.len().saturating_sub(SHOWN) {
        0 => String::new(),
        n => format!(" and {n} more"),
    };
    let _ = writeln!(
        s,
        "    pinned at (m): {}{more}",
        at[..at.len().min(SHOWN)].join(", ")
    );
}

/// The step, the stiffest mode, and each integrator's estimated stable dt.
fn solver(s: &mut String, model: &Model, settings: &Settings) {
    let _ = writeln!(
        s,
        "  solver: {}, dt = {:.4e} s ({} substeps per frame at {} Hz), {} frames ({:.3} s)",
        settings.integrator,
        settings.dt_secs,
        settings.substeps,
        settings.frame_rate_hz,
        settings.frames,
        settings.duration_secs()
    );
    let modes = Modes::of(model);
    let _ = writeln!(
        s,
        "  stiffest mode (bound): ω ≈ {:.4e} rad/s, damping ratio {:.3}, at mass {} ({})",
        modes.stiffest.value,
        modes.corner_damping_ratio(),
        modes.stiffest.mass,
        modes.stiffest.source
    );
    let _ = writeln!(
        s,
        "  most damped mode (bound): γ ≈ {:.4e} /s at mass {} ({}); the damping ratio above is γ/2ω",
        modes.most_damped.value, modes.most_damped.mass, modes.most_damped.source
    );
    if let Some(r) = modes.ratios {
        let _ = writeln!(
            s,
            "  damping per stiffness c/k: {:.3e} s ({}) to {:.3e} s",
            r.least_s, r.least, r.most_s
        );
    }
    let _ = writeln!(
        s,
        "  largest stable dt, estimated over every mode within those bounds (`hooke bench accuracy` measures it):"
    );
    for step in stable_steps(&modes, &settings.options) {
        let (i, dt) = (step.integrator, step.dt_secs);
        let by = step
            .limit
            .map(|l| format!(", {} limit", l.name()))
            .unwrap_or_default();
        // The run's integrator, with the step it takes against this limit (an arrow beside
        // a limit alone read as the step chosen).
        let mark = match (i == settings.integrator, dt) {
            (false, _) => String::new(),
            (true, Some(limit)) if limit.is_finite() && limit > 0.0 => format!(
                " <- this run: dt = {:.3e} s, {:.0}% of the limit",
                settings.dt_secs,
                100.0 * settings.dt_secs / limit
            ),
            (true, _) => format!(" <- this run: dt = {:.3e} s", settings.dt_secs),
        };
        match dt {
            Some(dt) if dt.is_finite() => {
                let substeps = (1.0 / (settings.frame_rate_hz * dt)).ceil();
                let plural = if substeps > 1.0 { "s" } else { "" };
                let _ = writeln!(
                    s,
                    "    {:<14} {dt:.3e} s ({substeps:.0} substep{plural}/frame{by}){mark}",
                    i.name(),
                );
            }
            Some(_) => match i.scheme().stable_step {
                hooke::integrator::StableStep::Any { why } => {
                    let _ = writeln!(s, "    {:<14} {why}{mark}", i.name());
                }
                hooke::integrator::StableStep::Limited => {
                    let _ = writeln!(
                        s,
                        "    {:<14} unlimited (no springs or contacts){mark}",
                        i.name()
                    );
                }
            },
            None => {
                let line = step
                    .dashpot_line_secs
                    .map(|l| format!("; the dashpots along the springs allow ≤ {l:.3e} s"))
                    .unwrap_or_default();
                let _ = writeln!(
                    s,
                    "    {:<14} no step stable for sure (a swing across stretched springs has no dashpot{line}){mark}",
                    i.name()
                );
            }
        }
    }
}

/// What preconditions implicit Euler's conjugate gradients on each backend.
fn preconditioner(s: &mut String, model: &Model, settings: &Settings) {
    use hooke::physics::Preconditioner;
    if !settings.integrator.newton() {
        return;
    }
    let stiffness = hooke::physics::stiffness_against_step(model, settings.step());
    let chosen = settings
        .options
        .preconditioner_for(model.mass_count(), stiffness);
    let least = hooke::physics::MULTIGRID_MIN_MASSES;
    let stiff = hooke::physics::MULTIGRID_MIN_STIFFNESS;
    let why = match settings.options.preconditioner {
        Some(_) => "as asked".to_owned(),
        None if chosen == Preconditioner::Multigrid => format!(
            "from {least} masses where the springs are stiff against the step ((h² Σk + h Σc) / m \
             up to {stiffness:.1}, multigrid from {stiff:.0})"
        ),
        None if model.mass_count() < least => format!("below {least} masses"),
        None => format!(
            "the springs are not stiff enough against the step for multigrid to pay ((h² Σk + h Σc) \
             / m up to {stiffness:.1}, multigrid from {stiff:.0})"
        ),
    };
    let hierarchy = (chosen == Preconditioner::Multigrid)
        .then(|| hooke::physics::hierarchy::Hierarchy::new(model))
        .flatten();
    let gpu = match hooke::gpu::implicit_path(model) {
        hooke::gpu::ImplicitPath::Passes => "on its per-pass path, a dispatch per level and pass",
        hooke::gpu::ImplicitPath::InGroup => "in its one-workgroup step, a loop per level and pass",
    };
    let _ = match hierarchy {
        Some(h) => writeln!(
            s,
            "  CG preconditioner: {} on both backends, {why} (coarse levels of {} nodes, the last \
             {}; the GPU's {gpu})",
            chosen.name(),
            h.nodes()
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" → "),
            if h.solves_coarsest() {
                "solved directly"
            } else {
                "swept, its coarsening stalled"
            }
        ),
        None if chosen == Preconditioner::Multigrid => writeln!(
            s,
            "  CG preconditioner: {} on both backends: {} was asked for, but the masses do not \
             coarsen into levels",
            Preconditioner::BlockJacobi.name(),
            chosen.name()
        ),
        None => writeln!(
            s,
            "  CG preconditioner: {} on both backends, {why}",
            Preconditioner::BlockJacobi.name()
        ),
    };
}
