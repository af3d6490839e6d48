//! What the probe concludes for one kernel family on one adapter, and the rule it judges by.

/// How far a mass may end from the CPU's after the probe's frames, where the two are not held to
/// bit for bit: 0.1 mm. A GPU sums implicit Euler's figures over its own threads and
/// workgroups, not in the CPU's lanes, so its solves may stop an iteration apart; over the
/// probe's three frames at one step per frame that left about 1e-6 m on lavapipe before its sums
/// were the CPU's, and 4.4e-6 m on an H100.
pub const TOLERANCE_M: f64 = 1e-4;

/// What the probe concluded for one family on one adapter.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Verdict {
    /// `KernelFamily::key`.
    pub family: String,
    /// The family's name as `check` prints it.
    pub name: String,
    pub agrees: bool,
    /// Bit for bit was asked (lavapipe, every family but multigrid's), and held where `agrees`.
    pub bitwise: bool,
    /// The largest distance of a mass from the CPU's, over the scenes probed.
    pub worst_m: f64,
    /// Where it was largest: the scene's name (none where no scene could take the family).
    pub scene: Option<String>,
    /// Every scene probed.
    pub scenes: Vec<String>,
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Some(scene) = &self.scene else {
            return write!(
                f,
                "{}: untested (no probe scene takes this path on this adapter)",
                self.name
            );
        };
        let rule = match self.bitwise {
            true => "bit for bit".to_owned(),
            false => format!("within {TOLERANCE_M:.0e} m"),
        };
        match self.agrees {
            true => write!(
                f,
                "{}: agrees with the CPU {rule} on {} (largest difference {:.2e} m, on {scene})",
                self.name,
                self.scenes.join(", "),
                self.worst_m
            ),
            false => write!(
                f,
                "{}: DISAGREES with the CPU: a mass ends {:.3e} m from the CPU's on {scene}, \
                 where the rule is {rule}",
                self.name, self.worst_m
            ),
        }
    }
}
