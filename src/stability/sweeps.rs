//! Whether a fixed number of Gauss–Seidel sweeps a step (XPBD's over the springs, VBD's over the
//! masses) converges the springs at the chosen step, or leaves an answer that is fast and wrong:
//! stable, but a body far softer than its springs (XPBD at 1/60 s on the peer cloth ends 20 times
//! lower than the fine-step reference).
//!
//! Both solve, each step, a system whose matrix scaled by the masses is I + s L: s = h² k / m the
//! springs' stiffness over a step, L the graph Laplacian of a body's springs (XPBD's compliance
//! form L + 1/s has the same condition number). A Gauss–Seidel sweep shrinks the error of the
//! slowest mode by about (1 − 1/κ)², κ = (1 + s λ_max) / (1 + s λ_min) the condition number, with
//! λ_max ≤ twice the most springs at a mass (Gershgorin) and λ_min ≈ (π / 2D)² for a body pinned
//! D springs from its farthest mass (the lowest mode of a string held at one end), (π / D)² for
//! a free body D springs across. After n sweeps the slowest stretch is corrected by
//! 1 − (1 − 1/κ)^(2n) of what the step asks; below a third, the body acts markedly softer than
//! its springs, and the run says so, and what would do. (The estimate is rough, a factor of two
//! in κ either way; hair with XPBD's one sweep at its own step corrects 46%, cloth with VBD's
//! ten sweeps at 1/60 s 2%, cloth-256 with them nothing measurable.)

use std::collections::VecDeque;

use crate::integrator::{Integrator, Sweeps};
use crate::model::Model;
use crate::scene::settings::Settings;

/// Below this share of the slowest stretch corrected per step, the sweeps are too few.
pub const SWEEPS_ENOUGH: f64 = 1.0 / 3.0;

/// A body whose slowest stretch the sweeps cannot converge at the step.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepShortfall {
    pub body: String,
    /// Share of the slowest stretch corrected per step.
    pub corrected: f64,
    /// Springs between the body's farthest mass and its pins (or across it, when free).
    pub hops: u32,
    pub pinned: bool,
    /// h² k / m of its stiffest spring at the step.
    pub stiffness_ratio: f64,
    /// Sweeps a step would need to correct `SWEEPS_ENOUGH` of it, and the step at which the
    /// given sweeps would.
    pub sweeps_needed: u64,
    pub step_that_would_secs: f64,
}

/// Every body's springs as the sweeps see them: what bounds XPBD's and VBD's step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepReach(Vec<BodySprings>);

/// The body whose springs bind the step at which the sweeps still converge them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Converging {
    /// The largest step at which `sweeps` sweeps correct [`SWEEPS_ENOUGH`] of every body's
    /// slowest stretch.
    pub dt_secs: f64,
    pub sweeps: u32,
    /// The binding body's springs from its farthest mass to its pins (or across it, when free).
    pub hops: u32,
    pub pinned: bool,
}

impl SweepReach {
    pub fn of(model: &Model) -> Self {
        Self(bodies(model))
    }

    /// The largest step at which `sweeps` sweeps a step still converge every body's springs
    /// as [`sweep_shortfall`] judges it, and the body that binds; `None` without springs.
    /// Beyond it a body stays stretched far past its springs' rest, with that stretch's
    /// energy: `hooke bench stability` measured every built-in scene holding to at least
    /// this step (docs/stability.md).
    pub fn converging(&self, sweeps: u32) -> Option<Converging> {
        self.0
            .iter()
            .filter(|b| b.k_over_m > 0.0)
            .map(|b| Converging {
                dt_secs: converging_step(b, sweeps, 1e3),
                sweeps,
                hops: b.hops,
                pinned: b.pinned,
            })
            .min_by(|a, b| a.dt_secs.total_cmp(&b.dt_secs))
    }
}

/// The largest step up to `below` at which `sweeps` sweeps still correct [`SWEEPS_ENOUGH`] of
/// `b`'s slowest stretch: `corrected` falls as the step grows, so bisect in log h.
fn converging_step(b: &BodySprings, sweeps: u32, below: f64) -> f64 {
    let (mut lo, mut hi) = (1e-12 * below, below);
    for _ in 0..80 {
        let mid = (lo * hi).sqrt();
        if corrected(b, mid, sweeps) >= SWEEPS_ENOUGH {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// What is known of a body's springs, independent of the step.
#[derive(Debug, Clone, PartialEq)]
struct BodySprings {
    name: String,
    /// Largest k / m over its springs (m the lighter movable end).
    k_over_m: f64,
    most_springs: usize,
    hops: u32,
    pinned: bool,
}

/// The share of the slowest stretch `sweeps` Gauss–Seidel sweeps correct at step `h`.
fn corrected(b: &BodySprings, h: f64, sweeps: u32) -> f64 {
    let s = h * h * b.k_over_m;
    let d = f64::from(b.hops.max(1));
    let lowest = if b.pinned {
        (std::f64::consts::PI / (2.0 * d)).powi(2)
    } else {
        (std::f64::consts::PI / d).powi(2)
    };
    let highest = 2.0 * b.most_springs as f64;
    let kappa = (1.0 + s * highest) / (1.0 + s * lowest);
    1.0 - (1.0 - 1.0 / kappa).powf(2.0 * f64::from(sweeps))
}

/// The body that falls shortest of converging, if any does, for XPBD's or VBD's sweeps at
/// `settings`' step (`None` for the other integrators).
pub fn sweep_shortfall(model: &Model, settings: &Settings) -> Option<SweepShortfall> {
    let sweeps = settings
        .integrator
        .scheme()
        .sweeps()?
        .count(&settings.options);
    let h = settings.dt_secs;
    bodies(model)
        .into_iter()
        .map(|b| (corrected(&b, h, sweeps), b))
        .filter(|(share, _)| *share < SWEEPS_ENOUGH)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(share, b)| {
            // Sweeps: the share grows with them; the step: it falls as the step does.
            let mut sweeps_needed = u64::from(sweeps);
            while corrected(&b, h, sweeps_needed.min(u64::from(u32::MAX)) as u32) < SWEEPS_ENOUGH
                && sweeps_needed < 1 << 30
            {
                sweeps_needed *= 2;
            }
            let lo = converging_step(&b, sweeps, h);
            SweepShortfall {
                corrected: share,
                hops: b.hops,
                pinned: b.pinned,
                stiffness_ratio: h * h * b.k_over_m,
                sweeps_needed,
                step_that_would_secs: lo,
                body: b.name,
            }
        })
}

/// The warning `check` and `run` print for [`sweep_shortfall`].
pub fn sweep_warning(model: &Model, settings: &Settings) -> Option<SweepWarning> {
    let short = sweep_shortfall(model, settings)?;
    let of = *settings.integrator.scheme().sweeps()?;
    Some(SweepWarning {
        integrator: settings.integrator,
        sweeps: of.count(&settings.options),
        of,
        dt_secs: settings.dt_secs,
        substeps: (1.0 / (settings.frame_rate_hz * short.step_that_would_secs)).ceil(),
        short,
    })
}

/// XPBD's or VBD's sweeps too few for the step, as [`sweep_warning`] finds them.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepWarning {
    pub integrator: Integrator,
    /// The run's sweeps.
    pub sweeps: u32,
    /// The scheme's sweeps: their flag, what they serve, and what to take instead.
    pub of: Sweeps,
    pub dt_secs: f64,
    /// Substeps a frame at the step that would converge.
    pub substeps: f64,
    pub short: SweepShortfall,
}

impl std::fmt::Display for SweepWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let SweepWarning {
            integrator,
            sweeps,
            of,
            dt_secs,
            substeps,
            short,
        } = self;
        let reach = if short.pinned {
            format!("its farthest mass {} springs from a pin", short.hops)
        } else {
            format!("{} springs across", short.hops)
        };
        write!(
            f,
            "`{integrator}` with {sweeps} sweep{} per {} corrects only {} of the slowest stretch \
             of body '{}' at dt = {dt_secs:.3e} s ({reach}, h²k/m = {:.3e}): it will sag and \
             stretch far more than its springs allow. Enough would be about {needed} sweeps ({} \
             {needed}), or dt ≤ {:.3e} s ({substeps} substeps per frame); or use {}",
            if *sweeps == 1 { "" } else { "s" },
            of.per,
            percent(short.corrected),
            short.body,
            short.stiffness_ratio,
            of.flag,
            short.step_that_would_secs,
            of.instead,
            needed = short.sweeps_needed,
        )
    }
}

/// A share as a percentage, two significant figures when small.
fn percent(share: f64) -> String {
    let p = 100.0 * share;
    if p >= 1.0 {
        format!("{p:.0}%")
    } else {
        format!("{p:.2}%")
    }
}

/// Each body's springs: their stiffest k/m, the most at a mass, and how many springs its
/// farthest mass is from a pin (from the far side, for a body without pins), counted along its
/// stiff springs (at least half the stiffest's k: a strand's bending springs, a quarter of its
/// structural ones on hair, are no shortcut for its stretch).
fn bodies(model: &Model) -> Vec<BodySprings> {
    model
        .bodies
        .iter()
        .map(|b| {
            let masses = b.masses.start as usize..b.masses.end as usize;
            let springs = &model.springs[b.springs.start as usize..b.springs.end as usize];
            let movable = |i: u32| model.inv_mass[i as usize] > 0.0;
            let k_over_m = springs
                .iter()
                .filter_map(|s| {
                    let m = [s.a, s.b]
                        .into_iter()
                        .filter(|&i| movable(i))
                        .map(|i| f64::from(model.mass_kg[i as usize]))
                        .reduce(f64::min)?;
                    Some(f64::from(s.stiffness_n_per_m) / m)
                })
                .fold(0.0, f64::max);
            let most_springs = masses
                .clone()
                .map(|i| model.adjacency.of(i).len())
                .max()
                .unwrap_or(0);
            let stiffest = springs
                .iter()
                .map(|s| s.stiffness_n_per_m)
                .fold(0.0f32, f32::max);
            let stiff = |k: u32| model.springs[k as usize].stiffness_n_per_m >= 0.5 * stiffest;
            let pins: Vec<usize> = masses.clone().filter(|&i| !movable(i as u32)).collect();
            let pinned = !pins.is_empty();
            let hops = if pinned {
                farthest(model, &pins, stiff).1
            } else {
                // Across: the farthest mass from the farthest mass from any one.
                let (far, _) = farthest(model, &[masses.start], stiff);
                farthest(model, &[far], stiff).1
            };
            BodySprings {
                name: b.name.clone(),
                k_over_m,
                most_springs,
                hops,
                pinned,
            }
        })
        .collect()
}

/// The mass farthest from `sources` along the springs `follow` takes (by index), and how many
/// springs away.
fn farthest(model: &Model, sources: &[usize], follow: impl Fn(u32) -> bool) -> (usize, u32) {
    let mut hops = vec![u32::MAX; model.mass_count()];
    let mut queue: VecDeque<usize> = sources.iter().copied().collect();
    for &s in sources {
        hops[s] = 0;
    }
    let mut last = (sources.first().copied().unwrap_or(0), 0);
    while let Some(i) = queue.pop_front() {
        last = (i, hops[i]);
        for nb in model.adjacency.of(i).iter().filter(|nb| follow(nb.spring)) {
            let j = nb.other as usize;
            if hops[j] == u32::MAX {
                hops[j] = hops[i] + 1;
                queue.push_back(j);
            }
        }
    }
    last
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shortfall(scene: &str, integrator: Integrator, dt: f64) -> Option<SweepShortfall> {
        let planned = crate::run::prepare::planned(scene).expect("a built-in scene");
        let settings = Settings {
            integrator,
            dt_secs: dt,
            ..planned.settings
        };
        sweep_shortfall(&planned.model, &settings)
    }

    #[test]
    fn one_sweep_at_the_scenes_own_step_is_enough_and_at_a_frame_is_not() {
        let own = crate::run::prepare::planned("hair")
            .expect("hair")
            .settings
            .dt_secs;
        assert_eq!(shortfall("hair", Integrator::Xpbd, own), None);
        let short = shortfall("cloth", Integrator::Xpbd, 1.0 / 60.0).expect("cloth at 1/60 s");
        assert!(short.corrected < 0.1 && short.pinned, "{short:?}");
        // The step it names is one where the same sweep would do.
        let at = shortfall("cloth", Integrator::Xpbd, short.step_that_would_secs * 0.99);
        assert_eq!(at, None);
        assert!(short.sweeps_needed > 10, "{short:?}");
        // Not an integrator of sweeps.
        assert_eq!(shortfall("cloth", Integrator::Implicit, 1.0 / 60.0), None);
    }

    #[test]
    fn a_strings_pinned_end_is_found_by_its_springs() {
        let planned = crate::run::prepare::planned("hair").expect("hair");
        let b = &bodies(&planned.model)[0];
        let n = planned.model.bodies[0].masses.len() as u32;
        // A strand pinned at its top: its last mass n − 1 structural springs away.
        assert!(b.pinned && b.hops == n - 1, "{} hops of {n} masses", b.hops);
    }
}
