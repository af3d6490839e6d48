//! `hooke bench throughput --effects`: what each effect of a scene costs to step.

use std::fmt::Write as _;

use crate::error::Result;
use crate::run::prepare::SceneSource;
use crate::scene::{self, Scene};

use super::throughput::{Throughput, ThroughputOptions, throughput_of};

/// What each effect of a scene costs: the scene as it is, then once without each effect it has.
pub struct EffectCosts {
    pub all: Throughput,
    /// (effect, the scene without it).
    pub without: Vec<(&'static str, Throughput)>,
}

/// The effects a scene has, each with the scene less that effect.
fn effect_variants(s: &Scene) -> Vec<(&'static str, Scene)> {
    let mut out = Vec::new();
    let mut variant = |name: &'static str, has: bool, drop: &dyn Fn(&mut Scene)| {
        if has {
            let mut v = s.clone();
            drop(&mut v);
            out.push((name, v));
        }
    };
    let e = &s.effects;
    variant("gravity", e.gravity_m_per_s2.is_some(), &|v| {
        v.effects.gravity_m_per_s2 = None
    });
    variant("air drag", e.air_drag_per_s.is_some(), &|v| {
        v.effects.air_drag_per_s = None
    });
    variant("ground", e.ground.is_some(), &|v| v.effects.ground = None);
    variant("spheres", !e.spheres.is_empty(), &|v| {
        v.effects.spheres.clear()
    });
    variant("boxes", !e.boxes.is_empty(), &|v| v.effects.boxes.clear());
    variant("planes", !e.planes.is_empty(), &|v| {
        v.effects.planes.clear()
    });
    variant("self-collision", e.self_collision.is_some(), &|v| {
        v.effects.self_collision = None
    });
    let bodies = |f: fn(&scene::Body) -> bool| s.bodies.iter().any(f);
    variant("plasticity", bodies(|b| b.plasticity.is_some()), &|v| {
        v.bodies.iter_mut().for_each(|b| b.plasticity = None)
    });
    variant("tearing", bodies(|b| b.tearing.is_some()), &|v| {
        v.bodies.iter_mut().for_each(|b| b.tearing = None)
    });
    variant(
        "spring damping",
        bodies(|b| {
            [b.springs.structural, b.springs.shear, b.springs.bending]
                .iter()
                .flatten()
                .any(|k| k.damping_n_s_per_m != 0.0)
        }),
        &|v| {
            for b in &mut v.bodies {
                for k in [
                    &mut b.springs.structural,
                    &mut b.springs.shear,
                    &mut b.springs.bending,
                ]
                .into_iter()
                .flatten()
                {
                    k.damping_n_s_per_m = 0.0;
                }
            }
        },
    );
    out
}

/// Time the scene with all its effects and without each in turn (`hooke bench throughput
/// --effects`). Removing an effect can change the motion too (no gravity, no falling), so the
/// difference is the cost of the effect's passes and terms on this scene, not a universal price.
pub fn effect_costs(scene_arg: &str, opts: &ThroughputOptions) -> Result<EffectCosts> {
    let scene = crate::run::prepare::planned(scene_arg)?.loaded.scene;
    // Differences of a few percent drown in run-to-run noise: each configuration runs
    // `EFFECT_REPEATS` times, interleaved, and keeps its fastest run.
    let variants = effect_variants(&scene);
    let mut all = throughput_of(variant(&scene), opts)?;
    let mut without = variants
        .iter()
        .map(|(name, v)| Ok((*name, throughput_of(variant(v), opts)?)))
        .collect::<Result<Vec<_>>>()?;
    let faster = |best: &mut Throughput, t: Throughput| {
        if t.wall_secs < best.wall_secs {
            *best = t;
        }
    };
    for _ in 1..EFFECT_REPEATS {
        faster(&mut all, throughput_of(variant(&scene), opts)?);
        for ((_, best), (_, v)) in without.iter_mut().zip(&variants) {
            faster(best, throughput_of(variant(v), opts)?);
        }
    }
    Ok(EffectCosts { all, without })
}

/// A scene made in code, to be prepared like a named one.
fn variant(scene: &Scene) -> SceneSource {
    SceneSource::Variant(Box::new(scene.clone()))
}

/// Runs of each configuration in `effect_costs`; the fastest counts.
const EFFECT_REPEATS: usize = 3;

pub fn format_effect_costs(c: &EffectCosts) -> String {
    let ms = |t: &Throughput| 1e3 / t.steps_per_sec();
    let all = ms(&c.all);
    let mut s = format!(
        "{}: {} masses, {} springs, {} on {}: {all:.4} ms per step with all its effects",
        c.all.scene,
        c.all.masses,
        c.all.springs,
        c.all.integrator.name(),
        c.all.backend
    );
    for (name, t) in &c.without {
        let without = ms(t);
        let _ = write!(
            s,
            "
  without {name:<15} {without:>9.4} ms per step: {name} costs {:>8.4} ms ({:>5.1}%)",
            all - without,
            100.0 * (all - without) / all
        );
    }
    s
}
