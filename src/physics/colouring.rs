//! Graph colourings both backends sweep in the same order: XPBD's colouring of the springs (the
//! springs of one colour share no movable mass, so they are projected at once, in any order,
//! with the same result on every CPU thread and on the GPU) and VBD's colouring of the masses
//! (the masses of one colour share no spring, so each is solved against neighbours that hold
//! still while its colour runs).

use crate::model::{Model, Spring};

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
    let (order, starts) = group_by_colour(&colour_of, colours);
    Colouring { order, starts }
}

/// Items (springs or masses) listed colour by colour, each colour's in increasing index, and
/// where each colour starts; an item without a colour is left out.
fn group_by_colour(colour_of: &[Option<u32>], colours: u32) -> (Vec<u32>, Vec<u32>) {
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
    (order, starts)
}

/// The movable masses grouped by colour: `order[starts[c]..starts[c + 1]]` are the masses of
/// colour `c`, in increasing index. No two masses of one colour are joined by a spring.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MassColouring {
    pub order: Vec<u32>,
    pub starts: Vec<u32>,
}

impl MassColouring {
    pub fn colours(&self) -> usize {
        self.starts.len() - 1
    }

    /// The masses of colour `c`.
    pub fn masses_of(&self, c: usize) -> &[u32] {
        &self.order[self.starts[c] as usize..self.starts[c + 1] as usize]
    }
}

/// Greedy colouring in mass order: each movable mass takes the lowest colour that none of its
/// spring neighbours (`neighbours(i)`) has taken. Pinned masses (inverse mass 0) are never
/// solved and take no colour. Deterministic: the result depends only on the adjacency.
pub fn colour_masses<I: IntoIterator<Item = u32>>(
    inv_mass: &[f32],
    neighbours: impl Fn(usize) -> I,
) -> MassColouring {
    let mut colour_of: Vec<Option<u32>> = vec![None; inv_mass.len()];
    let mut colours = 0u32;
    let mut taken: Vec<bool> = Vec::new();
    for i in 0..inv_mass.len() {
        if inv_mass[i] == 0.0 {
            continue;
        }
        taken.clear();
        for j in neighbours(i) {
            if let Some(c) = colour_of[j as usize] {
                let c = c as usize;
                if taken.len() <= c {
                    taken.resize(c + 1, false);
                }
                taken[c] = true;
            }
        }
        let c = taken.iter().position(|t| !t).unwrap_or(taken.len()) as u32;
        colour_of[i] = Some(c);
        colours = colours.max(c + 1);
    }
    let (order, starts) = group_by_colour(&colour_of, colours);
    MassColouring { order, starts }
}

/// VBD's colouring of `model`'s masses, through its springs (both backends sweep this one).
pub fn vbd_colouring(model: &Model) -> MassColouring {
    colour_masses(&model.inv_mass, |i| {
        model.adjacency.of(i).iter().map(|nb| nb.other)
    })
}
