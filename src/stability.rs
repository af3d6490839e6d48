//! How large a step the scene survives: a bound on its stiffest mode, fed to each integrator's
//! own amplification (see [`Integrator::stable_dt`]), and the warning a run gets when its step
//! is above that estimate.

use crate::integrator::Integrator;
use crate::model::Model;
use crate::settings::Settings;

/// The stiffest mode's angular frequency (an upper bound) and its damping ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffestMode {
    pub omega_rad_per_s: f64,
    pub damping_ratio: f64,
    /// The mass where the bound is reached.
    pub mass: u32,
}

/// Gershgorin bound on the largest eigenvalue of M^-1/2 K M^-1/2, where K holds the springs
/// (and any contact spring, which a mass may feel at any time; for mass–mass contact, one pair): ω² ≤ max_i Σ_j k_ij (1/m_i +
/// 1/√(m_i m_j)). Exact for a uniform chain. The damping ratio uses the same weights, which is
/// exact when damping is proportional to stiffness.
pub fn stiffest_mode(model: &Model) -> StiffestMode {
    let mut best = StiffestMode {
        omega_rad_per_s: 0.0,
        damping_ratio: 0.0,
        mass: 0,
    };
    let fx = &model.effects;
    // Mass–mass contact: one pair at a time, with the lightest free mass as the partner (the
    // stiffest such pair). A mass pressed by several at once is stiffer still; scenes keep a
    // margin below this estimate.
    let lightest = (0..model.mass_count())
        .filter(|&j| model.inv_mass[j] != 0.0)
        .map(|j| f64::from(model.mass_kg[j]))
        .fold(f64::INFINITY, f64::min);
    for i in 0..model.mass_count() {
        if model.inv_mass[i] == 0.0 {
            continue;
        }
        let mi = f64::from(model.mass_kg[i]);
        let (mut k, mut c) = (0.0f64, 0.0f64);
        for nb in model.adjacency.of(i) {
            let s = &model.springs[nb.spring as usize];
            let j = nb.other as usize;
            let w = 1.0 / mi
                + if model.inv_mass[j] == 0.0 {
                    0.0
                } else {
                    1.0 / (mi * f64::from(model.mass_kg[j])).sqrt()
                };
            k += f64::from(s.stiffness_n_per_m) * w;
            c += f64::from(s.damping_n_s_per_m) * w;
        }
        let contacts = fx
            .ground
            .iter()
            .map(|g| g.contact)
            .chain(fx.colliders.iter().map(|c| c.contact));
        for ct in contacts {
            let kc = f64::from(ct.stiffness_n_per_m);
            k += kc / mi;
            c += 2.0 * f64::from(ct.damping_ratio) * (kc * mi).sqrt() / mi;
        }
        if let Some(mc) = &fx.self_collision {
            let kc = f64::from(mc.contact.stiffness_n_per_m);
            let w = 1.0 / mi + 1.0 / (mi * lightest).sqrt();
            let mu = mi * lightest / (mi + lightest);
            k += kc * w;
            c += 2.0 * f64::from(mc.contact.damping_ratio) * (kc * mu).sqrt() * w;
        }
        if let Some(g) = fx.air_drag_per_s {
            c += f64::from(g);
        }
        if k > best.omega_rad_per_s * best.omega_rad_per_s {
            let omega = k.sqrt();
            best = StiffestMode {
                omega_rad_per_s: omega,
                damping_ratio: c / (2.0 * omega),
                mass: i as u32,
            };
        }
    }
    best
}

/// Estimated largest stable dt for each integrator; `None` where the scheme is unstable at any dt.
pub fn stable_dts(model: &Model) -> Vec<(Integrator, Option<f64>)> {
    let mode = stiffest_mode(model);
    Integrator::ALL
        .iter()
        .map(|&i| {
            (
                i,
                i.stable_dt(mode.omega_rad_per_s, mode.damping_ratio.min(1.0)),
            )
        })
        .collect()
}

/// Is the chosen dt above the estimated limit of the chosen integrator?
pub fn dt_warning(model: &Model, settings: &Settings) -> Option<String> {
    let limit = stable_dts(model)
        .into_iter()
        .find(|(i, _)| *i == settings.integrator)?
        .1;
    match limit {
        Some(l) if settings.dt_secs <= l => None,
        Some(l) => Some(format!(
            "dt = {:.3e} s is above the estimated stable limit {:.3e} s of `{}` for this scene's stiffest spring; \
             use at least {} substeps per frame (or --dt {:.1e})",
            settings.dt_secs,
            l,
            settings.integrator,
            (1.0 / (settings.frame_rate_hz * l)).ceil(),
            l
        )),
        None if has_no_damping(model) => Some(format!(
            "`{}` gains energy at every dt on this undamped scene; prefer semi-implicit, verlet or rk4",
            settings.integrator
        )),
        None => None,
    }
}

fn has_no_damping(model: &Model) -> bool {
    stiffest_mode(model).damping_ratio == 0.0
}
