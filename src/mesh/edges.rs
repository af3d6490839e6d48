//! A mesh's edges: each once, with the corners opposite it in the triangles that share it. A
//! cloth's structural springs are the edges, its bending springs join the two opposite corners of
//! an interior edge; a closed surface has exactly two triangles on every edge.

use std::collections::HashMap;

/// One edge, `a < b`, and what lies across it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    pub a: u32,
    pub b: u32,
    /// How many triangles share it: 1 on a border, 2 inside a manifold, more where it is not.
    pub faces: u32,
    /// The corner opposite the edge in its first two triangles.
    pub opposite: [u32; 2],
}

#[derive(Debug, Clone, Default)]
pub struct Edges {
    /// Sorted by `(a, b)`.
    pub edges: Vec<Edge>,
}

impl Edges {
    pub fn of(triangles: &[[u32; 3]]) -> Self {
        let mut at: HashMap<(u32, u32), usize> = HashMap::with_capacity(3 * triangles.len() / 2);
        let mut edges: Vec<Edge> = Vec::with_capacity(3 * triangles.len() / 2);
        for t in triangles {
            for k in 0..3 {
                let (p, q, o) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let key = (p.min(q), p.max(q));
                match at.get(&key) {
                    Some(&e) => {
                        let e = &mut edges[e];
                        if e.faces == 1 {
                            e.opposite[1] = o;
                        }
                        e.faces += 1;
                    }
                    None => {
                        at.insert(key, edges.len());
                        edges.push(Edge {
                            a: key.0,
                            b: key.1,
                            faces: 1,
                            opposite: [o, o],
                        });
                    }
                }
            }
        }
        edges.sort_unstable_by_key(|e| (e.a, e.b));
        Self { edges }
    }

    /// The first edge shared by more than two triangles.
    pub fn non_manifold(&self) -> Option<&Edge> {
        self.edges.iter().find(|e| e.faces > 2)
    }

    /// The first edge on a border (one triangle): `None` for a closed surface.
    pub fn border(&self) -> Option<&Edge> {
        self.edges.iter().find(|e| e.faces == 1)
    }

    /// Interior edges of a manifold: two triangles, two opposite corners.
    pub fn interior(&self) -> impl Iterator<Item = &Edge> {
        self.edges.iter().filter(|e| e.faces == 2)
    }
}
