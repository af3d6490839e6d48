//! One entry of a side-by-side comparison (`hooke run --compare`, a scene's `[compare]` table):
//! an integrator, and optionally its own step, as `rk4`, `implicit@1/60`, `semi-implicit@dt=1e-4`
//! or `xpbd@2e-4`. Parsed here, below the scene, so that a scene file's entries are checked as it
//! loads and the command line's the same way.

use std::fmt;

use crate::integrator::Integrator;

/// An integrator, and the step it takes when the entry gives one (else the scene's), with the
/// entry as the user wrote it (`implicit@1/60`), which labels its copy and its plot lines.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareEntry {
    pub integrator: Integrator,
    pub dt_secs: Option<f64>,
    pub typed: String,
}

/// Why an entry cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EntryError {
    #[error("an entry is empty: give an integrator, e.g. rk4 or implicit@1/60")]
    Empty,
    #[error("'{given}' names no integrator: use one of {}", names())]
    UnknownIntegrator { given: String },
    #[error("the step '{given}' is not a number of seconds: write it as 1/60, 1e-4 or dt=1e-4")]
    NotAStep { given: String },
    #[error("the step {dt_secs} s must be a positive, finite number of seconds")]
    NotPositive { dt_secs: f64 },
}

fn names() -> String {
    Integrator::ALL
        .iter()
        .map(|i| i.name())
        .collect::<Vec<_>>()
        .join(", ")
}

impl CompareEntry {
    /// `text` as `integrator[@step]`, the step as `1/60`, `1e-4` or `dt=1e-4` seconds.
    pub fn parse(text: &str) -> Result<Self, EntryError> {
        let text = text.trim();
        if text.is_empty() {
            return Err(EntryError::Empty);
        }
        let (name, step) = match text.split_once('@') {
            Some((n, s)) => (n.trim(), Some(s.trim())),
            None => (text, None),
        };
        let integrator = Integrator::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .ok_or_else(|| EntryError::UnknownIntegrator {
                given: name.to_owned(),
            })?;
        let dt_secs = step.map(parse_step).transpose()?;
        Ok(Self {
            integrator,
            dt_secs,
            typed: text.split_whitespace().collect(),
        })
    }

    /// Every entry of a comma-separated list, the first failure named by its position.
    pub fn parse_list(text: &str) -> Result<Vec<Self>, (usize, String, EntryError)> {
        text.split(',')
            .enumerate()
            .map(|(i, t)| Self::parse(t).map_err(|e| (i, t.trim().to_owned(), e)))
            .collect()
    }

    /// The entry's name in entity paths and plots: the integrator, and its step when it has its
    /// own (`implicit_dt_0.016667`), of letters, digits, `_`, `-` and `.` only.
    pub fn name(&self) -> String {
        match self.dt_secs {
            None => self.integrator.name().to_owned(),
            Some(dt) => format!("{}_dt_{}", self.integrator.name(), short(dt)),
        }
    }
}

/// A step in few digits: 0.016667, 1e-4.
fn short(dt: f64) -> String {
    let plain = format!("{dt:.6}");
    let plain = plain.trim_end_matches('0').trim_end_matches('.');
    if dt >= 1e-3
        && plain
            .parse::<f64>()
            .is_ok_and(|p| (p - dt).abs() <= 1e-4 * dt)
    {
        plain.to_owned()
    } else {
        format!("{dt:.3e}").replace(".000", "")
    }
}

/// A step as a user writes it, in seconds: `0.001`, `1e-3` or a fraction such as `1/60`
/// (`--dt` and `--compare` alike); `None` when `s` is neither.
pub fn seconds(s: &str) -> Option<f64> {
    match s.split_once('/') {
        Some((a, b)) => {
            let (a, b): (f64, f64) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
            Some(a / b)
        }
        None => s.trim().parse().ok(),
    }
}

fn parse_step(s: &str) -> Result<f64, EntryError> {
    let bad = || EntryError::NotAStep {
        given: s.to_owned(),
    };
    let s = s.strip_prefix("dt=").unwrap_or(s).trim();
    let value = seconds(s).ok_or_else(bad)?;
    if !(value.is_finite() && value > 0.0) {
        return Err(EntryError::NotPositive { dt_secs: value });
    }
    Ok(value)
}

/// As the user wrote it, spaces aside.
impl fmt::Display for CompareEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.typed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_read_as_written() {
        let e = |t| CompareEntry::parse(t).unwrap_or_else(|e| panic!("{t}: {e}"));
        assert_eq!(e("rk4").integrator, Integrator::Rk4);
        assert_eq!(e("rk4").dt_secs, None);
        assert_eq!(e("implicit@1/60").dt_secs, Some(1.0 / 60.0));
        assert_eq!(e("semi-implicit@dt=1e-4").dt_secs, Some(1e-4));
        assert_eq!(e(" xpbd @ 2e-4 ").dt_secs, Some(2e-4));
        assert_eq!(e("implicit@1/60").name(), "implicit_dt_0.016667");
        assert_eq!(e("semi-implicit@1e-4").name(), "semi-implicit_dt_1e-4");
        assert_eq!(e("rk4").name(), "rk4");
        assert_eq!(e(" xpbd @ 2e-4 ").to_string(), "xpbd@2e-4");
        assert_eq!(e("implicit@1/60").to_string(), "implicit@1/60");
    }

    #[test]
    fn bad_entries_say_what_is_wrong() {
        let err = |t| {
            CompareEntry::parse(t)
                .err()
                .unwrap_or_else(|| panic!("{t} parsed"))
        };
        assert_eq!(err(""), EntryError::Empty);
        assert!(matches!(err("rk5"), EntryError::UnknownIntegrator { .. }));
        assert!(matches!(err("rk4@fast"), EntryError::NotAStep { .. }));
        assert!(matches!(err("rk4@1/0"), EntryError::NotPositive { .. }));
        assert!(matches!(err("rk4@-1e-4"), EntryError::NotPositive { .. }));
        assert!(matches!(err("rk4@dt="), EntryError::NotAStep { .. }));
        assert_eq!(
            CompareEntry::parse_list("rk4,,xpbd").err().map(|e| e.0),
            Some(1)
        );
    }
}
