//! The modes that bound a scene's step, read off the model: a Gershgorin bound on the stiffest
//! mode and one on the most damped mode, and the range of damping-to-stiffness ratios.
//!
//! Linearised about a state, the masses obey `M x'' + C x' + K x = 0`. Every mode (u, λ) of that
//! system solves λ² + λ c_u + k_u = 0 with the Rayleigh quotients `k_u = u*Ku`, `c_u = u*Cu` of
//! the mass-weighted matrices, so each mode is a scalar damped oscillator with `ω² = k_u` and
//! damping rate `γ = c_u`, and (k_u, c_u) lies in a region this file bounds:
//! - `k_u ≤ max_i K_i` and `c_u ≤ max_i C_i`, the Gershgorin row bounds of the two matrices,
//!   each taken at its own mass (the stiffest and the most damped mode need not be the same);
//! - between the two lines `γ = β_min ω² + d` and `γ = β_max ω² + d`, where β = c/k ranges over
//!   the springs and contacts and d is the air drag: every spring adds `k x̂x̂ᵀ` to K and
//!   `c x̂x̂ᵀ` to C, so `C − β_min K − d I` and `β_max K + d I − C` are sums of positive parts.
//!
//! The lines hold for springs near their rest length. A spring stretched to length l under
//! tension T also stiffens sideways, by T/l ≤ k, with no dashpot across it: the bound on k_u
//! still holds, but those modes are damped by drag alone, which matters only to schemes that
//! need damping to be stable at all (forward Euler, RK2).

use std::fmt;

use crate::laws::spring_kind::SpringKindTag;
use crate::model::Model;

use super::crossing::Crossing;
use super::sweeps::SweepReach;

/// What a mode's stiffness or damping comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    Spring(SpringKindTag),
    Ground,
    /// The scene's collider of this index (spheres, then boxes, then planes).
    Collider(usize),
    MassContact,
    AirDrag,
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Source::Spring(kind) => write!(f, "{} springs", kind.name()),
            Source::Ground => f.write_str("ground contact"),
            Source::Collider(i) => write!(f, "collider {i}'s contact"),
            Source::MassContact => f.write_str("mass–mass contact"),
            Source::AirDrag => f.write_str("air drag"),
        }
    }
}

/// A Gershgorin row bound: its value, the mass where it is reached, and what adds most to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bound {
    pub value: f64,
    pub mass: u32,
    pub source: Source,
}

/// The damping-to-stiffness ratios c/k of every spring and contact (seconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ratios {
    pub least_s: f64,
    /// Whose ratio is the least: the dashpot that is weakest for its spring.
    pub least: Source,
    /// Infinite where a dashpot has no spring beside it.
    pub most_s: f64,
}

/// The region every mode of the scene lies in (see the file's comment).
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// The stiffest mode's angular frequency bound ω_max (rad/s): the square root of the
    /// largest row of M^-1/2 K M^-1/2's Gershgorin bound.
    pub stiffest: Bound,
    /// The most damped mode's rate bound γ_max (1/s), from M^-1/2 C M^-1/2 likewise.
    pub most_damped: Bound,
    /// None when nothing is stiff (no springs, no contacts).
    pub ratios: Option<Ratios>,
    /// Air drag (1/s), the damping every mode has.
    pub drag_per_s: f64,
    /// The region of the forces XPBD steps as semi-implicit Euler does, its springs aside:
    /// contacts and drag (`None` in that region itself).
    pub unprojected: Option<Box<Modes>>,
    /// How far XPBD's and VBD's sweeps must carry a correction through each body.
    pub reach: SweepReach,
    /// The step at which a mass can cross a collider's middle, a limit of every scheme.
    pub crossing: Option<Crossing>,
}

impl Modes {
    /// The damping ratio of the corner mode: the stiffest mode with the most damping any mode
    /// has, ζ = γ_max / (2 ω_max). The semi-implicit step is set by this corner.
    pub fn corner_damping_ratio(&self) -> f64 {
        if self.stiffest.value > 0.0 {
            self.most_damped.value / (2.0 * self.stiffest.value)
        } else {
            0.0
        }
    }

    /// The modes of the whole scene.
    pub fn of(model: &Model) -> Self {
        Self::over(model, 0..model.mass_count())
    }

    /// The modes bounded by the rows of these masses only: what one mass's own springs and
    /// contacts allow (a divergence is explained by its mass's row).
    pub fn at_mass(model: &Model, mass: u32) -> Self {
        Self::over(model, mass as usize..mass as usize + 1)
    }

    fn over(model: &Model, masses: std::ops::Range<usize>) -> Self {
        let mut modes = Self::region(model, masses.clone(), true);
        // The contacts and the drag alone, the springs aside.
        modes.unprojected = Some(Box::new(Self::region(model, masses, false)));
        modes.reach = SweepReach::of(model);
        modes.crossing = Crossing::of(model);
        modes
    }

    /// The region bounded by these masses' rows, with their springs or without them.
    fn region(model: &Model, masses: std::ops::Range<usize>, springs: bool) -> Self {
        let drag = model.effects.air_drag_per_s.map_or(0.0, f64::from);
        let mut stiffest = Bound {
            value: 0.0,
            mass: masses.start as u32,
            source: Source::AirDrag,
        };
        let mut most_damped = Bound {
            value: drag,
            mass: masses.start as u32,
            source: Source::AirDrag,
        };
        let mut ratios: Option<Ratios> = None;
        let lightest = lightest_free_mass(model);
        for i in masses {
            if model.inv_mass[i] == 0.0 {
                continue;
            }
            let row = Row::of(model, i, lightest, springs);
            if let Some(r) = row.ratios {
                widen(&mut ratios, r);
            }
            if row.stiffness > stiffest.value * stiffest.value {
                stiffest = Bound {
                    value: row.stiffness.sqrt(),
                    mass: i as u32,
                    source: row.stiffest_source,
                };
            }
            let damping = row.damping + drag;
            if damping > most_damped.value {
                most_damped = Bound {
                    value: damping,
                    mass: i as u32,
                    source: row.damped_source,
                };
            }
        }
        Self {
            stiffest,
            most_damped,
            ratios,
            drag_per_s: drag,
            unprojected: None,
            reach: SweepReach::default(),
            crossing: None,
        }
    }
}

/// `into` widened to cover `r` as well.
fn widen(into: &mut Option<Ratios>, r: Ratios) {
    match into {
        None => *into = Some(r),
        Some(into) => {
            if r.least_s < into.least_s {
                into.least_s = r.least_s;
                into.least = r.least;
            }
            into.most_s = into.most_s.max(r.most_s);
        }
    }
}

fn lightest_free_mass(model: &Model) -> f64 {
    (0..model.mass_count())
        .filter(|&j| model.inv_mass[j] != 0.0)
        .map(|j| f64::from(model.mass_kg[j]))
        .fold(f64::INFINITY, f64::min)
}

/// One mass's Gershgorin row of M^-1/2 K M^-1/2 and of M^-1/2 C M^-1/2 (drag aside), by
/// source, with the c/k ratio of each stiff part.
struct Row {
    stiffness: f64,
    damping: f64,
    stiffest_source: Source,
    damped_source: Source,
    ratios: Option<Ratios>,
}

impl Row {
    fn of(model: &Model, i: usize, lightest: f64, springs: bool) -> Self {
        let mi = f64::from(model.mass_kg[i]);
        // (source, k part, c part), summed per source so that the largest contributor is named.
        let mut parts: Vec<(Source, f64, f64)> = Vec::new();
        let mut add =
            |source: Source, k: f64, c: f64| match parts.iter_mut().find(|p| p.0 == source) {
                Some(p) => {
                    p.1 += k;
                    p.2 += c;
                }
                None => parts.push((source, k, c)),
            };
        let mut ratios = None;
        let mut ratio = |source: Source, k: f64, c: f64| {
            let r = if k > 0.0 {
                c / k
            } else if c > 0.0 {
                f64::INFINITY
            } else {
                return;
            };
            let one = Ratios {
                least_s: r,
                least: source,
                most_s: r,
            };
            widen(&mut ratios, one);
        };
        let neighbours = if springs { model.adjacency.of(i) } else { &[] };
        for nb in neighbours {
            let s = &model.springs[nb.spring as usize];
            let j = nb.other as usize;
            // A pinned neighbour has no row of its own to couple to: only the diagonal counts.
            let w = 1.0 / mi
                + if model.inv_mass[j] == 0.0 {
                    0.0
                } else {
                    1.0 / (mi * f64::from(model.mass_kg[j])).sqrt()
                };
            let (k, c) = (
                f64::from(s.stiffness_n_per_m),
                f64::from(s.damping_n_s_per_m),
            );
            let source = Source::Spring(model.spring_kind[nb.spring as usize]);
            add(source, k * w, c * w);
            ratio(source, k, c);
        }
        let fx = &model.effects;
        let contacts = fx.ground.iter().map(|g| (Source::Ground, g.contact)).chain(
            fx.colliders
                .iter()
                .enumerate()
                .map(|(n, c)| (Source::Collider(n), c.contact)),
        );
        for (source, ct) in contacts {
            // A penalty spring to a fixed body, damped `2ζ sqrt(k m)` per mass.
            let kc = f64::from(ct.stiffness_n_per_m);
            let cc = 2.0 * f64::from(ct.damping_ratio) * (kc * mi).sqrt();
            add(source, kc / mi, cc / mi);
            ratio(source, kc, cc);
        }
        if let Some(mc) = &fx.self_collision {
            // One pair at a time, with the lightest free mass as the partner (the stiffest such
            // pair), damped `2ζ sqrt(k μ)` with the pair's reduced mass μ.
            let kc = f64::from(mc.contact.stiffness_n_per_m);
            let w = 1.0 / mi + 1.0 / (mi * lightest).sqrt();
            let mu = mi * lightest / (mi + lightest);
            let cc = 2.0 * f64::from(mc.contact.damping_ratio) * (kc * mu).sqrt();
            add(Source::MassContact, kc * w, cc * w);
            ratio(Source::MassContact, kc, cc);
        }
        let largest = |by: fn(&(Source, f64, f64)) -> f64| {
            parts
                .iter()
                .max_by(|a, b| by(a).total_cmp(&by(b)))
                .map_or(Source::AirDrag, |p| p.0)
        };
        Self {
            stiffness: parts.iter().map(|p| p.1).sum(),
            damping: parts.iter().map(|p| p.2).sum(),
            stiffest_source: largest(|p| p.1),
            damped_source: largest(|p| p.2),
            ratios,
        }
    }
}
