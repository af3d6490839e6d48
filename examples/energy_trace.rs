//! Step a scene headless on the CPU backend and print its energies every few frames: a quick way
//! to see that a scene (or an edit of one) behaves before recording it.
//!
//! `cargo run --release --example energy_trace -- jello [every_n_frames]`

use hooke::integrator::Step;

use hooke::run::select::{self, BackendKind};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "jello".to_owned());
    let every: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(30);
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned(&name)?;
    let mut be = select::create(
        BackendKind::Cpu,
        model.clone(),
        Step::new(settings.integrator, settings.dt_secs),
        None,
    )?;
    println!(
        "{:>6} {:>8} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11} {:>9} {:>6}",
        "frame",
        "t (s)",
        "kinetic",
        "elastic",
        "gravity",
        "contact",
        "dissipated",
        "coll.work",
        "balance",
        "min y",
        "proj"
    );
    let mut stats = Default::default();
    for frame in 0..=settings.frames {
        if frame > 0 {
            stats = be.advance(settings.substeps)?;
        }
        if frame % every == 0 || frame == settings.frames {
            let s = be.snapshot(frame, stats)?;
            let e = s.energies;
            let min_y = s
                .positions
                .iter()
                .map(|p| p.y)
                .fold(f32::INFINITY, f32::min);
            println!(
                "{:>6} {:>8.3} {:>11.5} {:>11.5} {:>11.5} {:>11.5} {:>11.5} {:>11.5} {:>11.6} {:>9.4} {:>6}",
                frame,
                s.time_secs,
                e.kinetic_j,
                e.elastic_j,
                e.gravity_j,
                e.contact_j,
                e.ledger.dissipated_j(),
                e.ledger.collider_work_j,
                e.balance_j(),
                min_y,
                s.stats.projections
            );
        }
    }
    Ok(())
}
