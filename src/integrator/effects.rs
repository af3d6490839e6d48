//! The effects an integrator may refuse, and the rule that says which: written once, asked by
//! the scene as it loads, by the backends, and by the accuracy bench.

use super::table::Integrator;

/// An effect that some integrator cannot simulate, as [`Integrator::supports`] says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Unsupported {
    /// Mass–mass contact has no Jacobian in implicit Euler's system (a pair couples two masses
    /// along a normal that changes as they move): entering through the force only, stiff
    /// contacts would stall Newton, and VBD, which solves the same system, likewise.
    #[error("{} does not support {}", self.integrator_title(), self.effect())]
    MassContact(Integrator),
}

impl Unsupported {
    /// The effect, as a message names it.
    pub fn effect(self) -> &'static str {
        match self {
            Unsupported::MassContact(_) => "mass–mass contact",
        }
    }

    /// The integrator that refuses it, as a sentence names it.
    fn integrator_title(self) -> &'static str {
        match self {
            Unsupported::MassContact(i) => i.scheme().title,
        }
    }

    /// The scene file's table that asks for the effect.
    pub fn scene_field(self) -> &'static str {
        match self {
            Unsupported::MassContact(_) => "effects.self_collision",
        }
    }

    /// The integrators that do support it, by name: `semi-implicit, verlet or rk4`, each name
    /// between `quote`s.
    pub fn instead(self, quote: &str) -> String {
        let suggested: &[Integrator] = match self {
            Unsupported::MassContact(_) => &Integrator::STABLE_EXPLICIT,
        };
        let names: Vec<String> = suggested
            .iter()
            .filter(|i| i.supports(&self).is_ok())
            .map(|i| format!("{quote}{}{quote}", i.name()))
            .collect();
        match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }
}

/// An effect refused stands for a scene that asks for just that effect.
impl AskedEffects for Unsupported {
    fn mass_contact(&self) -> bool {
        matches!(self, Unsupported::MassContact(_))
    }
}

/// The effects a scene asks for, as far as an integrator may refuse them: the scene file's
/// `[effects]` (checked as it loads) and a built model's `Effects` (checked by the backends and
/// the accuracy bench) both answer, so the rule is written once, in [`Integrator::supports`].
pub trait AskedEffects {
    fn mass_contact(&self) -> bool;
}

impl Integrator {
    /// Whether this integrator can simulate every effect in `effects`; the one it cannot, if any.
    pub fn supports(self, effects: &impl AskedEffects) -> Result<(), Unsupported> {
        if self.scheme().assembles_blocks() && effects.mass_contact() {
            return Err(Unsupported::MassContact(self));
        }
        Ok(())
    }
}
