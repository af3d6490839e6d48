//! Filling a closed surface with a jello lattice: the cells of a grid at `spacing_m` that lie
//! inside the surface (by their centres) or hold one of its vertices, their corners the masses,
//! and each surface vertex embedded in its cell, following the cell's eight corners (trilinear
//! weights), so that the user's own surface is what is drawn.

use glam::Vec3;

/// No node at this grid point.
const NONE: u32 = u32::MAX;

/// A surface vertex placed in a lattice cell: its position is Σ weights · corners.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Embedded {
    /// Node indices of the cell's corners, corner `c` at offset (c & 1, c >> 1 & 1, c >> 2).
    pub corners: [u32; 8],
    pub weights: [f32; 8],
}

impl Embedded {
    /// Where the vertex is when the corners are at `x` (`base` added to each corner's index).
    pub fn position(&self, x: &[Vec3], base: u32) -> Vec3 {
        self.corners
            .iter()
            .zip(&self.weights)
            .map(|(&c, &w)| w * x[(base + c) as usize])
            .sum()
    }

    /// The corner with the largest weight.
    pub fn nearest(&self) -> u32 {
        let mut best = 0;
        for c in 1..8 {
            if self.weights[c] > self.weights[best] {
                best = c;
            }
        }
        self.corners[best]
    }
}

/// The lattice's nodes: grid points that are corners of kept cells, numbered in grid order
/// (x fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeNodes {
    /// Nodes along each axis of the whole grid (cells + 1).
    pub n: [u32; 3],
    pub origin: Vec3,
    pub spacing: f32,
    /// Grid coordinates of each node.
    pub nodes: Vec<[u32; 3]>,
    node_at: Vec<u32>,
    kept: Vec<bool>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    pub nodes: LatticeNodes,
    /// Per surface vertex, in the surface's order.
    pub embedded: Vec<Embedded>,
}

/// Cells along each axis for `extent` at `spacing` (at least one), as the fill lays them out.
pub fn cells_for(extent: Vec3, spacing: f32) -> [u64; 3] {
    extent
        .to_array()
        .map(|e| ((f64::from(e) / f64::from(spacing)).floor() as u64).saturating_add(1))
}

impl Lattice {
    /// Fill the closed surface (`positions`, `triangles`) with cells of `spacing`.
    pub fn fill(positions: &[Vec3], triangles: &[[u32; 3]], spacing: f32) -> Self {
        let (lo, hi) = bounds(positions);
        let cells = cells_for(hi - lo, spacing).map(|c| c as u32);
        // Centred on the surface: the slack is shared by both sides of each axis.
        let span = Vec3::new(cells[0] as f32, cells[1] as f32, cells[2] as f32) * spacing;
        let origin = lo - 0.5 * (span - (hi - lo));
        let n = cells.map(|c| c + 1);
        let cell_index = |c: [u32; 3]| (c[0] + cells[0] * (c[1] + cells[1] * c[2])) as usize;
        let mut kept = vec![false; cells.iter().map(|&c| c as usize).product()];
        // Inside by the parity of crossings on a ray along +x through each row of cell centres.
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                // Nudged off the centre by odd fractions of a cell: a ray through a mesh laid on
                // the same grid would run along its triangles' shared edges, where a crossing
                // can count twice or not at all.
                let y = origin.y + (j as f32 + 0.500_137) * spacing;
                let z = origin.z + (k as f32 + 0.500_291) * spacing;
                let mut hits = crossings(positions, triangles, y, z);
                hits.sort_by(f32::total_cmp);
                for i in 0..cells[0] {
                    let x = origin.x + (i as f32 + 0.5) * spacing;
                    let before = hits.iter().take_while(|&&h| h < x).count();
                    if before % 2 == 1 {
                        kept[cell_index([i, j, k])] = true;
                    }
                }
            }
        }
        let cell_of = |p: Vec3| {
            let t = (p - origin) / spacing;
            let c = [t.x, t.y, t.z];
            let cell: [u32; 3] =
                std::array::from_fn(|a| (c[a].floor().max(0.0) as u32).min(cells[a] - 1));
            let local = Vec3::from_array(std::array::from_fn(|a| {
                (c[a] - cell[a] as f32).clamp(0.0, 1.0)
            }));
            (cell, local)
        };
        for p in positions {
            kept[cell_index(cell_of(*p).0)] = true;
        }
        let node_count: usize = n.iter().map(|&c| c as usize).product();
        let mut is_node = vec![false; node_count];
        let node_index = |g: [u32; 3]| (g[0] + n[0] * (g[1] + n[1] * g[2])) as usize;
        for k in 0..cells[2] {
            for j in 0..cells[1] {
                for i in 0..cells[0] {
                    if kept[cell_index([i, j, k])] {
                        for c in 0..8u32 {
                            let g = [i + (c & 1), j + (c >> 1 & 1), k + (c >> 2)];
                            is_node[node_index(g)] = true;
                        }
                    }
                }
            }
        }
        let mut node_at = vec![NONE; node_count];
        let mut nodes = Vec::new();
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    if is_node[node_index([i, j, k])] {
                        node_at[node_index([i, j, k])] = nodes.len() as u32;
                        nodes.push([i, j, k]);
                    }
                }
            }
        }
        let embedded = positions
            .iter()
            .map(|p| {
                let (cell, t) = cell_of(*p);
                let mut e = Embedded {
                    corners: [0; 8],
                    weights: [0.0; 8],
                };
                for c in 0..8u32 {
                    let d = [c & 1, c >> 1 & 1, c >> 2];
                    let g = [cell[0] + d[0], cell[1] + d[1], cell[2] + d[2]];
                    e.corners[c as usize] = node_at[node_index(g)];
                    let w = |a: usize, f: f32| if d[a] == 1 { f } else { 1.0 - f };
                    e.weights[c as usize] = w(0, t.x) * w(1, t.y) * w(2, t.z);
                }
                e
            })
            .collect();
        Self {
            nodes: LatticeNodes {
                n,
                origin,
                spacing,
                nodes,
                node_at,
                kept,
            },
            embedded,
        }
    }
}

impl LatticeNodes {
    pub fn position(&self, node: u32) -> Vec3 {
        let g = self.nodes[node as usize];
        self.origin + self.spacing * Vec3::new(g[0] as f32, g[1] as f32, g[2] as f32)
    }

    fn node(&self, g: [i64; 3]) -> Option<u32> {
        if (0..3).any(|a| g[a] < 0 || g[a] >= i64::from(self.n[a])) {
            return None;
        }
        let i = g[0] + i64::from(self.n[0]) * (g[1] + i64::from(self.n[1]) * g[2]);
        let v = self.node_at[i as usize];
        (v != NONE).then_some(v)
    }

    fn cell_kept(&self, c: [i64; 3]) -> bool {
        let cells = self.n.map(|x| i64::from(x) - 1);
        if (0..3).any(|a| c[a] < 0 || c[a] >= cells[a]) {
            return false;
        }
        self.kept[(c[0] + cells[0] * (c[1] + cells[1] * c[2])) as usize]
    }

    /// The node that a spring from `node` along grid offset `off` reaches, when the lattice
    /// joins them: a kept cell holds both (offsets of at most one step per axis), or each half
    /// is joined (a bending spring's two steps).
    pub fn joined(&self, node: u32, off: [i32; 3]) -> Option<u32> {
        let g = self.nodes[node as usize].map(i64::from);
        if off.iter().any(|o| o.abs() > 1) {
            let half = off.map(|o| o / 2);
            if off.iter().any(|o| o % 2 != 0) {
                return None;
            }
            let mid = self.joined(node, half)?;
            return self.joined(mid, half);
        }
        let q = [0, 1, 2].map(|a| g[a] + i64::from(off[a]));
        let other = self.node(q)?;
        // The cells holding both ends: per axis, c in [max − 1, min].
        let range = |a: usize| (g[a].max(q[a]) - 1)..=g[a].min(q[a]);
        for cz in range(2) {
            for cy in range(1) {
                for cx in range(0) {
                    if self.cell_kept([cx, cy, cz]) {
                        return Some(other);
                    }
                }
            }
        }
        None
    }
}

fn bounds(positions: &[Vec3]) -> (Vec3, Vec3) {
    positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

/// Where the line {y, z} crosses the triangles, as x coordinates.
fn crossings(positions: &[Vec3], triangles: &[[u32; 3]], y: f32, z: f32) -> Vec<f32> {
    let mut out = Vec::new();
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        // Barycentrics of (y, z) in the triangle's projection on the yz plane.
        let d = (b.y - a.y) * (c.z - a.z) - (c.y - a.y) * (b.z - a.z);
        if d == 0.0 {
            continue;
        }
        let u = ((y - a.y) * (c.z - a.z) - (c.y - a.y) * (z - a.z)) / d;
        let v = ((b.y - a.y) * (z - a.z) - (y - a.y) * (b.z - a.z)) / d;
        if u >= 0.0 && v >= 0.0 && u + v < 1.0 {
            out.push(a.x + u * (b.x - a.x) + v * (c.x - a.x));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed cube of side `s` centred at the origin (12 triangles).
    fn cube(s: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let h = 0.5 * s;
        let p: Vec<Vec3> = (0..8)
            .map(|c| {
                Vec3::new(
                    if c & 1 == 1 { h } else { -h },
                    if c & 2 == 2 { h } else { -h },
                    if c & 4 == 4 { h } else { -h },
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (p, t)
    }

    #[test]
    fn a_cube_fills_with_its_cells_and_its_corners_embed_exactly() {
        let (p, t) = cube(1.0);
        let l = Lattice::fill(&p, &t, 0.3);
        // ⌊1 / 0.3⌋ + 1 = 4 cells a side, every centre inside the cube.
        assert_eq!(l.nodes.n, [5, 5, 5]);
        assert_eq!(l.nodes.nodes.len(), 125);
        let x: Vec<Vec3> = (0..l.nodes.nodes.len() as u32)
            .map(|v| l.nodes.position(v))
            .collect();
        for (e, q) in l.embedded.iter().zip(&p) {
            assert!((e.position(&x, 0) - *q).length() < 1e-5);
            assert!((e.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn a_sphere_keeps_the_cells_inside_and_joins_only_through_kept_cells() {
        // An octahedron: the cells near its corners are inside, those at the box's corners not.
        let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let t = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        let l = Lattice::fill(&p, &t, 0.25);
        let n = &l.nodes;
        // The corner node of the box is nobody's: no kept cell reaches it.
        assert!(n.node([0, 0, 0]).is_none());
        let centre = n.node([4, 4, 4]).expect("the centre is inside");
        assert!(n.joined(centre, [1, 0, 0]).is_some());
        assert!(n.joined(centre, [2, 0, 0]).is_some());
        assert!(n.nodes.len() < 9 * 9 * 9);
    }
}
