//! `hooke check`: the model a scene builds, and whether the chosen step is stable.

use std::fmt::Write as _;

use hooke::model::{BodyShape, Collider, MeshVertices, Model, Path, Shape, SpringKindTag};
use hooke::run::prepare::Planned;
use hooke::run::select::BackendKind;
use hooke::scene::settings::Settings;
use hooke::stability::{Modes, dt_warning, stable_steps, sweep_warning};

use super::args::DeviceArgs;

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
    if here != hooke::gpu::step_passes(model, settings.step()).0 {
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
    gpu_passes(&mut s, model, settings);
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

/// Every effect the scene has, with its parameters; "none" when it has none.
fn effects(s: &mut String, model: &Model) {
    let e = &model.effects;
    let _ = writeln!(s, "  effects:");
    let mut any = false;
    if let Some(g) = e.gravity_m_per_s2 {
        let _ = writeln!(s, "    gravity {:?} m/s²", g.to_array());
        any = true;
    }
    if let Some(d) = e.air_drag_per_s {
        let _ = writeln!(s, "    air drag {d} /s");
        any = true;
    }
    if let Some(g) = &e.ground {
        let _ = writeln!(
            s,
            "    ground at y = {} m: stiffness {} N/m, friction {}, damping ratio {:.3}",
            g.height_m, g.contact.stiffness_n_per_m, g.contact.friction, g.contact.damping_ratio
        );
        any = true;
    }
    let mut counts = std::collections::HashMap::new();
    for c in &e.colliders {
        let i = counts.entry(c.kind()).or_insert(0usize);
        *i += 1;
        let _ = writeln!(s, "{}", collider(c, *i - 1));
        any = true;
    }
    for b in &model.bodies {
        let Some(l) = model.limits.get(b.springs.start as usize) else {
            continue;
        };
        if l.yield_strain.is_finite() {
            let _ = writeln!(
                s,
                "    plasticity of '{}': yield strain {}, creep {} /s",
                b.name, l.yield_strain, l.creep_per_s
            );
            any = true;
        }
        if l.break_strain.is_finite() {
            let _ = writeln!(
                s,
                "    tearing of '{}': springs break past strain {}",
                b.name, l.break_strain
            );
            any = true;
        }
    }
    if let Some(c) = &e.self_collision {
        let _ = writeln!(
            s,
            "    self-collision ({}): radius {} m, stiffness {} N/m per pair, friction {}, damping ratio {:.3} (with the pair's reduced mass); neighbour lists of the masses within {:.4} m, rebuilt once a mass has moved {:.4} m, through a hash grid of {} buckets",
            if c.within_bodies {
                "within and between bodies"
            } else {
                "between bodies only"
            },
            c.radius_m,
            c.contact.stiffness_n_per_m,
            c.contact.friction,
            c.contact.damping_ratio,
            hooke::physics::neighbour_reach_m(c.radius_m),
            hooke::physics::neighbour_moved_limit_m(c.radius_m),
            hooke::physics::table_size(model.mass_count())
        );
        any = true;
    }
    if !any {
        let _ = writeln!(s, "    none");
    }
}

/// One collider: its shape, its path and its contact.
fn collider(c: &Collider, i: usize) -> String {
    let shape = match c.shape {
        Shape::Sphere { radius_m } => format!("radius {radius_m} m"),
        Shape::Box { half_extents_m } => {
            format!("half extents {:?} m", half_extents_m.to_array())
        }
        Shape::Plane { normal } => format!("normal {:?}", normal.to_array()),
    };
    let path = match &c.path {
        Path::Linear { start_m, .. } if c.path.is_fixed() => {
            format!("fixed at {:?} m", start_m.to_array())
        }
        Path::Linear {
            start_m,
            velocity_m_per_s,
        } => format!(
            "from {:?} m at {:?} m/s",
            start_m.to_array(),
            velocity_m_per_s.to_array()
        ),
        Path::Keyframes(keys) => format!(
            "on {} keyframes from {:.3} s to {:.3} s",
            keys.len(),
            keys.first().map_or(0.0, |k| k.0),
            keys.last().map_or(0.0, |k| k.0)
        ),
    };
    format!(
        "    {} {i}: {shape}, {path}, stiffness {} N/m, friction {}, damping ratio {:.3}",
        c.kind(),
        c.contact.stiffness_n_per_m,
        c.contact.friction,
        c.contact.damping_ratio
    )
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
    for step in stable_steps(&modes) {
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
                let _ = writeln!(
                    s,
                    "    {:<14} {:.3e} s ({:.0} substeps/frame{by}){mark}",
                    i.name(),
                    dt,
                    (1.0 / (settings.frame_rate_hz * dt)).ceil()
                );
            }
            Some(_) if i == hooke::integrator::Integrator::Xpbd => {
                let _ = writeln!(
                    s,
                    "    {:<14} any for one spring in theory (a projection is a backward-Euler step of it); coupled springs at large substeps stay stretched, and their energy swings: `hooke bench accuracy` measures it{mark}",
                    i.name()
                );
            }
            Some(_) if i == hooke::integrator::Integrator::Vbd => {
                let _ = writeln!(
                    s,
                    "    {:<14} any in theory (backward Euler's equations; too few sweeps leave a stiff body soft, and this command says so below){mark}",
                    i.name()
                );
            }
            Some(_) if i == hooke::integrator::Integrator::Implicit => {
                let _ = writeln!(
                    s,
                    "    {:<14} any in theory (A-stable on linear springs; it damps, so accuracy still wants small steps){mark}",
                    i.name()
                );
            }
            Some(_) if i == hooke::integrator::Integrator::Bdf2 => {
                let _ = writeln!(
                    s,
                    "    {:<14} any in theory (A-stable on linear springs, second order: it damps slow motion far less than implicit Euler; on springs extremely stiff against the step take implicit, whose damping absorbs what an inexact step leaves){mark}",
                    i.name()
                );
            }
            Some(_) => {
                let _ = writeln!(
                    s,
                    "    {:<14} unlimited (no springs or contacts){mark}",
                    i.name()
                );
            }
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

/// The passes one GPU step runs, and the effects compiled into its kernels.
fn gpu_passes(s: &mut String, model: &Model, settings: &Settings) {
    let (passes, why_unfused, effects) = hooke::gpu::step_passes(model, settings.step());
    let _ = writeln!(s, "  GPU step passes: {}", passes.join(" → "));
    if passes.iter().any(|p| p == "fused_frame") {
        use hooke::gpu::one_group_step_masses;
        use wgpu::DeviceType::{Cpu, DiscreteGpu};
        let _ = writeln!(
            s,
            "  fused_frame: every step of a submission in one dispatch of one workgroup (up to {} \
             masses on a GPU, {} on a CPU adapter; larger scenes take fused_step), the state in \
             workgroup memory between steps where {} B a mass fits the adapter's (its line below), else \
             in the state buffers",
            one_group_step_masses(DiscreteGpu),
            one_group_step_masses(Cpu),
            hooke::gpu::FRAME_STATE_BYTES_PER_MASS
        );
    }
    match why_unfused {
        Some(why) => {
            let _ = writeln!(s, "  not the fused step: {why}");
        }
        None if passes.iter().any(|p| p.starts_with("fused_")) => {
            let one_group = passes.iter().any(|p| p == "fused_frame");
            let single = matches!(
                settings.integrator,
                hooke::integrator::Integrator::Euler | hooke::integrator::Integrator::SemiImplicit
            );
            if single && !one_group {
                let device = wgpu::DeviceType::DiscreteGpu;
                if let Some(why) = hooke::gpu::why_not_in_group(model, settings.integrator, device)
                {
                    let _ = writeln!(s, "  a dispatch per step, not one a submission: {why}");
                }
            }
            let (bodies, masses) = hooke::gpu::stencil_cover(model);
            let _ = writeln!(
                s,
                "  grid stencils: {masses} of {} masses ({bodies} grid {}) find their springs \
                 from their grid cell, the others read a link per spring",
                model.mass_count(),
                if bodies == 1 { "body" } else { "bodies" }
            );
        }
        None => {}
    }
    colour_sweeps(s, model, settings);
    let _ = writeln!(
        s,
        "  compiled-in effects: {}",
        if effects.is_empty() {
            "none".to_owned()
        } else {
            effects.join(", ")
        }
    );
}

/// XPBD's or VBD's sweeps: their colours, and whether a step (a substep, XPBD's) sweeps them in
/// one dispatch of one workgroup or a dispatch per colour and sweep.
fn colour_sweeps(s: &mut String, model: &Model, settings: &Settings) {
    use hooke::integrator::Integrator;
    use wgpu::DeviceType::{Cpu, DiscreteGpu};
    // Per integrator: its colours, the line's head, its kernel, what a plan of sweeps serves,
    // and its lanes.
    let (dispatches, head, (kernel, per), lanes) = match settings.integrator {
        Integrator::Xpbd => {
            let colours = hooke::physics::colour_springs(&model.springs, &model.inv_mass).colours();
            let iterations = settings.options.xpbd_iterations;
            let head = format!("XPBD: {colours} spring colours × {iterations} iteration(s)");
            (
                colours as u32 * iterations,
                head,
                ("xpbd_solve_spring", "substep"),
                String::new(),
            )
        }
        Integrator::Vbd => {
            let colours = hooke::physics::vbd_colouring(model).colours();
            let sweeps = settings.options.vbd_iterations;
            let head = format!("VBD: {colours} mass colours × {sweeps} sweep(s)");
            let lanes = format!(
                "; each mass's springs shared among {} threads on a GPU",
                hooke::gpu::vbd_lanes(DiscreteGpu)
            );
            (
                colours as u32 * sweeps,
                head,
                ("vbd_solve_mass", "step"),
                lanes,
            )
        }
        _ => return,
    };
    let in_group = |device| {
        let run = (settings.integrator, settings.options);
        hooke::gpu::sweeps_in_one_group(model, run, device)
    };
    let how = match (in_group(DiscreteGpu), in_group(Cpu)) {
        (true, true) => format!("all in one dispatch of one workgroup per {per}"),
        (true, false) => format!(
            "all in one dispatch of one workgroup per {per} on a GPU; {dispatches} {kernel} \
             dispatches per {per} on a CPU adapter, which runs a workgroup on one core"
        ),
        _ => format!("{dispatches} {kernel} dispatches per {per}"),
    };
    let _ = writeln!(s, "  {head}: {how}{lanes}");
}
