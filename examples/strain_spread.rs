//! How strained a scene's springs get over its run, to choose its `[view] strain_range` from: the
//! 50th, 90th, 95th and 99th percentiles and the largest |strain| of the springs its surfaces are
//! coloured by (structural ones, where it has any), every tenth frame of its first 180, stepped
//! headless on the CPU. The built-in scenes take about their 99th percentile, so that the colour
//! scale spans what most springs do and a few hot spots saturate.
//!
//! `cargo run --release --example strain_spread -- cloth jello`

use hooke::integrator::Step;
use hooke::run::select::{self, BackendKind};

fn main() -> anyhow::Result<()> {
    let names: Vec<String> = std::env::args().skip(1).collect();
    for name in names {
        let p = hooke::run::prepare::planned(&name)?;
        let m = p.model.clone();
        let step = Step::new(p.settings.integrator, p.settings.dt_secs);
        let mut be = select::create(BackendKind::Cpu, m.clone(), step, None)?;
        let shown = hooke::record::labelled_springs(&m);
        let mut all = Vec::new();
        let frames = p.settings.frames.min(180);
        for f in 0..=frames {
            let stats = if f > 0 {
                be.advance(p.settings.substeps)?
            } else {
                Default::default()
            };
            if f % 10 == 0 {
                let s = be.snapshot(f, stats)?;
                let kept = s
                    .strain
                    .iter()
                    .enumerate()
                    .filter(|(i, st)| st.is_finite() && shown.as_ref().is_none_or(|k| k[*i]));
                all.extend(kept.map(|(_, st)| st.abs()));
            }
        }
        all.sort_by(|a, b| a.total_cmp(b));
        let Some(&largest) = all.last() else {
            println!("{name:14} no springs");
            continue;
        };
        let q = |p: f64| all[((all.len() - 1) as f64 * p) as usize];
        println!(
            "{name:14} p50 {:.4} p90 {:.4} p95 {:.4} p99 {:.4} max {largest:.4} (strain_range {})",
            q(0.5),
            q(0.9),
            q(0.95),
            q(0.99),
            p.loaded.scene.view.strain_range
        );
    }
    Ok(())
}
