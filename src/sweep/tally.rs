//! What an executor keeps as the points it runs end: the count of each outcome, a line per
//! point, and the bar they are drawn above.

use super::plan::{Layout, Plan};
use super::result::{self, Status};

/// How the points an executor ran ended.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    pub ok: usize,
    pub diverged: usize,
    pub refused: usize,
    pub failed: usize,
    /// Ended without a result (killed, or lost), with why where known.
    pub lost: Vec<(usize, String)>,
}

impl Tally {
    /// Count point `index`, which has ended: its line for the terminal. `why_lost` says why
    /// where it left no result.
    pub fn add(
        &mut self,
        layout: &Layout,
        plan: &Plan,
        index: usize,
        why_lost: impl FnOnce() -> String,
    ) -> String {
        let label = plan.points[index].label();
        match result::read(&layout.result(index)) {
            Some(r) => {
                match r.status {
                    Status::Ok => self.ok += 1,
                    Status::Diverged => self.diverged += 1,
                    Status::Refused => self.refused += 1,
                    Status::Failed => self.failed += 1,
                }
                let why = match (&r.message, r.first_sentence(), r.notes.len()) {
                    // A divergence's first sentence says where; its advice is in result.json.
                    (Some(m), Some(first), _)
                        if r.status == Status::Diverged && first.len() < m.len() =>
                    {
                        format!(": {first}. (result.json has the rest)")
                    }
                    (Some(m), ..) => format!(": {m}"),
                    (None, _, 0) => String::new(),
                    (None, _, n) => {
                        format!(", with {n} note(s) (result.json has them): {}", r.notes[0])
                    }
                };
                format!("point {index} ({label}): {}{why}", r.status)
            }
            None => {
                let why = why_lost();
                self.lost.push((index, why.clone()));
                format!("point {index} ({label}): no result: {why}")
            }
        }
    }

    /// Points without a usable result.
    pub fn unfinished(&self) -> usize {
        self.failed + self.lost.len()
    }

    pub fn brief(&self) -> String {
        let mut parts = vec![format!("{} ok", self.ok)];
        for (n, what) in [
            (self.diverged, "diverged"),
            (self.refused, "refused"),
            (self.failed, "failed"),
            (self.lost.len(), "without a result"),
        ] {
            if n > 0 {
                parts.push(format!("{n} {what}"));
            }
        }
        parts.join(", ")
    }
}

/// A bar of points: drawn on a terminal when `show`, hidden otherwise (its lines still print).
pub fn bar(points: u64, show: bool) -> indicatif::ProgressBar {
    let bar = if show {
        indicatif::ProgressBar::new(points)
    } else {
        indicatif::ProgressBar::with_draw_target(
            Some(points),
            indicatif::ProgressDrawTarget::hidden(),
        )
    };
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{bar:30} {pos}/{len} points, {msg}; {elapsed} so far, about {eta} left",
    ) {
        bar.set_style(style);
    }
    bar
}

/// A line above the bar, or on its own where no bar is drawn.
pub fn say(bar: &indicatif::ProgressBar, shown: bool, line: String) {
    match shown {
        true => bar.println(line),
        false => eprintln!("{line}"),
    }
}
