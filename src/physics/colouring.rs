//! XPBD's graph colouring of the springs: the springs of one colour share no movable mass, so
//! they are projected at once, in any order, with the same result on every CPU thread and on the
//! GPU (both backends sweep the colours this computes).

use crate::model::Spring;

/// The springs grouped by colour: `order[starts[c]..starts[c + 1]]` are the springs of colour
/// `c`, in increasing index. No two springs of one colour share a mass that can move.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Colouring {
    pub order: Vec<u32>,
    pub starts: Vec<u32>,
}

impl Colouring {
    pub fn colours(&self) -> usize {
        self.starts.len() - 1
    }

    /// The springs of colour `c`.
    pub fn springs_of(&self, c: usize) -> &[u32] {
        &self.order[self.starts[c] as usize..self.starts[c + 1] as usize]
    }
}

/// Greedy colouring in spring order: each spring takes the lowest colour that no earlier spring
/// at one of its movable masses has. A pinned mass (inverse mass 0) is never moved, so springs
/// meeting only there may share a colour. Springs between two pinned masses move nothing and are
/// left out. Deterministic: the result depends only on the spring list.
pub fn colour_springs(springs: &[Spring], inv_mass: &[f32]) -> Colouring {
    let mut used: Vec<Vec<u32>> = vec![Vec::new(); inv_mass.len()];
    let mut colour_of: Vec<Option<u32>> = Vec::with_capacity(springs.len());
    let mut colours = 0u32;
    for s in springs {
        let ends: Vec<usize> = [s.a as usize, s.b as usize]
            .into_iter()
            .filter(|&m| inv_mass[m] > 0.0)
            .collect();
        if ends.is_empty() {
            colour_of.push(None);
            continue;
        }
        let c = (0..)
            .find(|c| ends.iter().all(|&m| !used[m].contains(c)))
            .unwrap_or(0);
        for &m in &ends {
            used[m].push(c);
        }
        colours = colours.max(c + 1);
        colour_of.push(Some(c));
    }
    let mut starts = vec![0u32; colours as usize + 1];
    for c in colour_of.iter().flatten() {
        starts[*c as usize + 1] += 1;
    }
    for c in 0..colours as usize {
        starts[c + 1] += starts[c];
    }
    let mut next = starts.clone();
    let mut order = vec![0u32; starts[colours as usize] as usize];
    for (i, c) in colour_of.iter().enumerate() {
        if let Some(c) = c {
            order[next[*c as usize] as usize] = i as u32;
            next[*c as usize] += 1;
        }
    }
    Colouring { order, starts }
}
