//! `hooke sweep plan`: each point and what it will cost, from what `check` knows before anything
//! runs: the step and its estimated stable limit, masses × steps, and the recording's size.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::sync::Arc;

use crate::error::Result;
use crate::record::RecordOptions;
use crate::record::rrd_file::human_bytes;
use crate::scene::settings::{Overrides, Settings};

use super::plan::Plan;

/// The plan as a table, with totals.
pub fn describe(plan: &Plan) -> Result<String> {
    let mut out = format!(
        "sweep of '{}': {} point{}{}, {} timed run{} each{}\n",
        plan.scene,
        plan.points.len(),
        if plan.points.len() == 1 { "" } else { "s" },
        match plan.varied.is_empty() {
            true => String::new(),
            false => format!(" varying {}", plan.varied.join(", ")),
        },
        plan.repeat,
        if plan.repeat == 1 { "" } else { "s" },
        match plan.points.first().and_then(|p| p.reference.as_ref()) {
            Some(_) => ", errors against the [reference]",
            None => "",
        }
    );
    let w = plan
        .points
        .iter()
        .map(|p| p.label().len())
        .max()
        .unwrap_or(5)
        .max(5);
    let _ = writeln!(
        out,
        "{:>5}  {:<w$} {:>8} {:>10} {:>11} {:>10} {:>13} {:>10}",
        "#", "point", "backend", "dt (s)", "steps", "mass·steps", "stable dt (s)", "recording"
    );
    let origin = plan.origin();
    let mut sizes: HashMap<(usize, usize, u64), u64> = HashMap::new();
    let (mut work, mut bytes, mut above) = (0f64, 0u64, 0usize);
    for p in &plan.points {
        let scene = crate::scene::from_toml(&p.scene_toml, origin.clone())
            .map_err(|e| crate::Error::Scene(e.into()))?;
        let settings = match Settings::resolve(&scene, &Overrides::default()) {
            Ok(s) => s,
            Err(e) => {
                let _ = writeln!(out, "{:>5}  {:<w$} refused: {e}", p.index, p.label());
                continue;
            }
        };
        let model = Arc::new(crate::model::build(&scene));
        let steps = settings.frames * u64::from(settings.substeps);
        let mass_steps = model.mass_count() as f64 * steps as f64;
        let stable = crate::stability::stable_step_with(
            &crate::stability::Modes::of(&model),
            settings.integrator,
            &settings.options,
        )
        .finite_dt();
        let is_above = stable.is_some_and(|s| settings.dt_secs > s * (1.0 + 1e-9));
        let key = (model.mass_count(), model.spring_count(), settings.frames);
        let size = match sizes.get(&key) {
            Some(&s) => s,
            None => {
                let record = RecordOptions::default().for_scene(&scene);
                let s = crate::run::recording_size::estimate(&model, &settings, record)?
                    .total(settings.frames);
                sizes.insert(key, s);
                s
            }
        };
        work += mass_steps;
        bytes += size;
        above += usize::from(is_above);
        let _ = writeln!(
            out,
            "{:>5}  {:<w$} {:>8} {:>10.3e} {:>11} {:>10.2e} {:>13} {:>10}",
            p.index,
            p.label(),
            p.backend,
            settings.dt_secs,
            steps,
            mass_steps,
            match stable {
                Some(s) => format!("{s:.3e}{}", if is_above { " *" } else { "" }),
                None => "any".to_owned(),
            },
            human_bytes(size)
        );
    }
    let _ = writeln!(
        out,
        "total: {work:.2e} mass·steps{}, recordings about {}{}",
        match plan.repeat {
            1 => String::new(),
            n => format!(" (× {} with the timed runs)", n + 1),
        },
        human_bytes(bytes),
        match above {
            0 => String::new(),
            n => format!("; {n} point(s) above check's estimated stable step (*)"),
        }
    );
    Ok(out)
}
