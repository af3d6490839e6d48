//! Surfaces: every sheet (2D grid) and the outer faces of every block (3D grid) as a triangle
//! mesh whose vertices are the body's masses; a mesh body's own triangles, over its masses
//! (cloth) or following its lattice's cells (a filled soft body).
//!
//! Triangles: each grid quad is split along its (0,0)–(1,1) diagonal. A triangle's edges are the
//! springs joining its corners (structural along the grid, shear on the diagonal, where the body
//! has them); a triangle is drawn while none of its edge springs is broken, so a tear opens in
//! the surface.
//!
//! Colour of a vertex, the documented function the tests check:
//!
//! ```text
//! strain(v) = the signed strain of the most strained intact structural spring at v (largest
//!             |strain|; springs of every kind where the body has no structural springs, as a
//!             body built by hand; 0 when none is intact)
//! colour(v) = shaded(strain_color(strain(v), strain_range), shade(n(v)))
//! ```
//!
//! Structural springs, because they carry the sheet's stretch: a draped cloth's bending and
//! shear springs shorten by tens of percent where it folds, which would paint every fold fully
//! blue and hide the stretch the scale is for. (Hover a spring, with `--springs all`, for the
//! others.) `n(v)` is the vertex normal (area-weighted sum of the normals of its intact triangles)
//! and `shade` is the viewer's own lighting (see [`shade`]). Rerun lights a mesh only where it is
//! given normals, at 12 bytes per vertex per frame, 40% of a cloth-256 frame: instead each frame
//! carries the lit colour, computed here with the viewer's lighting function, and no normals.

use std::collections::HashMap;

use glam::Vec3;

use super::surface_strain::{BlockStrain, Blocks, NO_VERTEX, vertex_strain};
use crate::model::{BodyInfo, BodyShape, MeshShape, MeshVertices, Model, SpringKindTag};

/// No spring joins these two corners.
const NO_SPRING: u32 = u32::MAX;

/// The surface of one body.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Mass index (model-wide) of each vertex.
    pub vertex_mass: Vec<u32>,
    /// Every triangle of the intact surface, as vertex indices.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the springs along its three edges (`NO_SPRING` where none).
    edge_springs: Vec<[u32; 3]>,
    /// A sheet is seen from both sides; a block's faces only from outside.
    pub two_sided: bool,
    /// Some edge spring may break: the triangle list changes over the run.
    pub can_tear: bool,
    /// A lattice-filled mesh's vertices follow their cells' corners (then `vertex_mass` holds
    /// each vertex's nearest corner, whose strain colours it).
    embedding: Option<Vec<crate::mesh::Embedded>>,
    /// A reduced surface: each vertex stands for a block of masses.
    blocks: Option<std::sync::Arc<Blocks>>,
}

/// Grid axes of a body that have more than one mass, with their sizes and index strides.
fn grid_axes(grid: &[u32]) -> Vec<(usize, u32)> {
    grid.iter()
        .enumerate()
        .filter(|(_, n)| **n > 1)
        .map(|(a, n)| (a, *n))
        .collect()
}

/// A body's surface as quads of four grid corners, counter-clockwise seen from the side they
/// face, and whether it is two-sided (a sheet); `None` for a strand. `coords[a]` are the grid
/// indices along axis `a` that are vertices (all of them, or every k-th and the last).
fn surface_quads(
    n: [u32; 3],
    axes: &[(usize, u32)],
    coords: &[Vec<u32>; 3],
) -> Option<(Vec<[[u32; 3]; 4]>, bool)> {
    let mut quads: Vec<[[u32; 3]; 4]> = Vec::new();
    let two_sided = match axes.len() {
        2 => {
            let (u, w) = (axes[0].0, axes[1].0);
            push_face(&mut quads, coords, u, w, None);
            true
        }
        3 => {
            // Six faces: for each axis d, the layer at index 0 and at n[d] − 1.
            for (d, u, w) in [(2, 0, 1), (0, 1, 2), (1, 2, 0)] {
                push_face(&mut quads, coords, u, w, Some((d, 0)));
                push_face(&mut quads, coords, u, w, Some((d, n[d] - 1)));
            }
            false
        }
        _ => return None,
    };
    Some((quads, two_sided))
}

/// How much of a large grid body's surface a recording holds (`--surface`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SurfaceDetail {
    /// At most about 256 vertices along each grid axis: every k-th grid vertex (and the last),
    /// each coloured by the most strained structural spring of the block of masses it stands
    /// for, so that a hot spot never disappears.
    #[default]
    Auto,
    /// Every vertex.
    Full,
}

/// The most vertices a reduced surface has along a grid axis (about: the last index is kept).
pub const MAX_SURFACE_SIDE: u32 = 256;

/// The grid indices along an axis of `n` masses that are vertices: every `stride`-th and the last.
fn axis_coords(n: u32, stride: u32) -> Vec<u32> {
    let mut c: Vec<u32> = (0..n).step_by(stride as usize).collect();
    if c.last() != Some(&(n - 1)) {
        c.push(n - 1);
    }
    c
}

impl Surface {
    /// The body's surface, or `None` for a strand (fewer than two grid axes with extent).
    pub fn of_body(model: &Model, body: &BodyInfo, detail: SurfaceDetail) -> Option<Self> {
        let grid = match &body.shape {
            BodyShape::Grid(g) => g,
            BodyShape::Mesh(m) => return Some(Self::of_mesh(model, body, m)),
        };
        let axes = grid_axes(grid);
        let n = [0, 1, 2].map(|a| grid.get(a).copied().unwrap_or(1));
        let stride = [1, n[0], n[0] * n[1]];
        let base = body.masses.start;
        let mass_at = |c: [u32; 3]| base + c[0] * stride[0] + c[1] * stride[1] + c[2] * stride[2];
        // Every k-th vertex where an axis is longer than MAX_SURFACE_SIDE, unless full detail is
        // asked for or a spring may tear (a torn triangle is a spring's, which a block hides).
        let may_tear = !model.limits.is_empty()
            && body
                .springs
                .clone()
                .any(|s| model.limits[s as usize].break_strain.is_finite());
        let k = match detail {
            SurfaceDetail::Full => 1,
            SurfaceDetail::Auto if may_tear => 1,
            SurfaceDetail::Auto => n
                .iter()
                .map(|&m| m.div_ceil(MAX_SURFACE_SIDE))
                .max()
                .unwrap_or(1),
        };
        let coords = n.map(|m| axis_coords(m, k));
        let (quads, two_sided) = surface_quads(n, &axes, &coords)?;
        // Vertices: every mass that a quad touches, in mass order.
        let mut used: Vec<u32> = quads.iter().flatten().map(|c| mass_at(*c)).collect();
        used.sort_unstable();
        used.dedup();
        let vertex_of: HashMap<u32, u32> = used
            .iter()
            .enumerate()
            .map(|(v, m)| (*m, v as u32))
            .collect();
        // Which spring each triangle edge is matters only where springs may break.
        let spring_of = if may_tear {
            springs_by_ends(model, body)
        } else {
            HashMap::new()
        };
        let x = &model.initial.x;
        let centre = {
            let r = body.masses.start as usize..body.masses.end as usize;
            x[r.clone()].iter().copied().sum::<Vec3>() / r.len().max(1) as f32
        };
        let mut triangles = Vec::with_capacity(2 * quads.len());
        let mut edge_springs = Vec::with_capacity(2 * quads.len());
        for q in &quads {
            let m = q.map(mass_at);
            let mut tris = [[m[0], m[1], m[2]], [m[0], m[2], m[3]]];
            if !two_sided {
                // A block's face must face out: its normal points away from the body's centre.
                let (a, b, c) = (x[m[0] as usize], x[m[1] as usize], x[m[2] as usize]);
                let normal = (b - a).cross(c - a);
                if normal.dot(a - centre) < 0.0 {
                    tris = tris.map(|[p, q, r]| [p, r, q]);
                }
            }
            for t in tris {
                let edge = |p: u32, q: u32| {
                    spring_of
                        .get(&(p.min(q), p.max(q)))
                        .copied()
                        .unwrap_or(NO_SPRING)
                };
                edge_springs.push([edge(t[0], t[1]), edge(t[1], t[2]), edge(t[2], t[0])]);
                triangles.push(t.map(|m| vertex_of[&m]));
            }
        }
        let can_tear = can_tear(model, &edge_springs);
        let blocks = (k > 1).then(|| {
            // A mass stands in the block of the vertex at or before it along each axis.
            let rep = |c: u32| c - c % k;
            let vertex_of_mass = |m: u32| {
                let i = m - base;
                let c = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
                let on_face = axes.len() == 2 || (0..3).any(|a| c[a] == 0 || c[a] == n[a] - 1);
                let r = [0, 1, 2].map(|a| if c[a] == n[a] - 1 { c[a] } else { rep(c[a]) });
                on_face
                    .then(|| vertex_of.get(&mass_at(r)).copied())
                    .flatten()
                    .unwrap_or(NO_VERTEX)
            };
            let springs = body
                .springs
                .clone()
                .filter(|&s| model.spring_kind[s as usize] == SpringKindTag::Structural)
                .filter_map(|s| {
                    let sp = &model.springs[s as usize];
                    let (va, vb) = (vertex_of_mass(sp.a), vertex_of_mass(sp.b));
                    (va != NO_VERTEX || vb != NO_VERTEX).then_some([s, va, vb])
                })
                .collect();
            std::sync::Arc::new(Blocks { stride: k, springs })
        });
        Some(Self {
            vertex_mass: used,
            triangles,
            edge_springs,
            two_sided,
            can_tear,
            embedding: None,
            blocks,
        })
    }

    /// Every how many grid vertices along an axis one is recorded (1: all of them).
    pub fn stride(&self) -> u32 {
        self.blocks.as_ref().map_or(1, |b| b.stride)
    }

    /// Each vertex's strain: [`vertex_strain`] at its mass, or on a reduced surface the most
    /// strained intact structural spring touching its block of masses.
    pub fn strain(&self, model: &Model, strain: &[f32], out: &mut Vec<f32>) {
        match self.block_strain() {
            None => vertex_strain(model, strain, &self.vertex_mass, out),
            Some(b) => b.of(strain, out),
        }
    }

    /// A reduced surface's vertex strains, as a value another thread can make them with.
    pub(super) fn block_strain(&self) -> Option<BlockStrain> {
        self.blocks.as_ref().map(|b| BlockStrain {
            blocks: b.clone(),
            vertices: self.vertex_mass.len(),
        })
    }

    /// A mesh body's own triangles. Cloth tears where its edge springs break; a lattice's
    /// surface follows the lattice and is drawn whole.
    fn of_mesh(model: &Model, body: &BodyInfo, mesh: &MeshShape) -> Self {
        let two_sided = !mesh.closed;
        match &mesh.vertices {
            MeshVertices::Masses(masses) => {
                let spring_of = springs_by_ends(model, body);
                let edge = |p: u32, q: u32| {
                    let (a, b) = (masses[p as usize], masses[q as usize]);
                    spring_of
                        .get(&(a.min(b), a.max(b)))
                        .copied()
                        .unwrap_or(NO_SPRING)
                };
                let edge_springs: Vec<[u32; 3]> = mesh
                    .triangles
                    .iter()
                    .map(|t| [edge(t[0], t[1]), edge(t[1], t[2]), edge(t[2], t[0])])
                    .collect();
                Self {
                    vertex_mass: masses.clone(),
                    triangles: mesh.triangles.clone(),
                    can_tear: can_tear(model, &edge_springs),
                    edge_springs,
                    two_sided,
                    embedding: None,
                    blocks: None,
                }
            }
            MeshVertices::Embedded(embedded) => Self {
                vertex_mass: embedded.iter().map(|e| e.nearest()).collect(),
                triangles: mesh.triangles.clone(),
                edge_springs: vec![[NO_SPRING; 3]; mesh.triangles.len()],
                two_sided,
                can_tear: false,
                embedding: Some(embedded.clone()),
                blocks: None,
            },
        }
    }

    /// The vertices' positions when the masses are at `x`.
    pub fn positions(&self, x: &[Vec3], out: &mut Vec<Vec3>) {
        out.clear();
        match &self.embedding {
            Some(e) => out.extend(e.iter().map(|e| e.position(x, 0))),
            None => out.extend(self.vertex_mass.iter().map(|&m| x[m as usize])),
        }
    }

    /// Whether the vertices are exactly the body's masses in order (a sheet, a mesh cloth):
    /// then a frame's positions are a slice of the snapshot's, with nothing to gather.
    pub fn is_whole_body(&self, body: &BodyInfo) -> bool {
        self.embedding.is_none()
            && self.vertex_mass.len() == (body.masses.end - body.masses.start) as usize
            && self.vertex_mass.first() == Some(&body.masses.start)
    }

    /// The triangles none of whose edge springs is broken (strain NaN).
    pub fn intact_triangles(&self, strain: &[f32]) -> Vec<[u32; 3]> {
        self.triangles
            .iter()
            .zip(&self.edge_springs)
            .filter(|(_, e)| {
                e.iter()
                    .all(|&s| s == NO_SPRING || !strain[s as usize].is_nan())
            })
            .map(|(t, _)| *t)
            .collect()
    }
}

/// Each of the body's springs by its two ends (lower first).
fn springs_by_ends(model: &Model, body: &BodyInfo) -> HashMap<(u32, u32), u32> {
    body.springs
        .clone()
        .map(|s| {
            let sp = &model.springs[s as usize];
            ((sp.a.min(sp.b), sp.a.max(sp.b)), s)
        })
        .collect()
}

/// Whether some edge spring may break.
fn can_tear(model: &Model, edge_springs: &[[u32; 3]]) -> bool {
    !model.limits.is_empty()
        && edge_springs
            .iter()
            .flatten()
            .any(|&s| s != NO_SPRING && model.limits[s as usize].break_strain.is_finite())
}

/// Quads of one grid face spanned by axes `u` and `w`, between consecutive vertex coordinates,
/// at `layer = (axis, index)` for a block's face or across the whole (2D) grid.
fn push_face(
    quads: &mut Vec<[[u32; 3]; 4]>,
    coords: &[Vec<u32>; 3],
    u: usize,
    w: usize,
    layer: Option<(usize, u32)>,
) {
    for jw in coords[w].windows(2) {
        for iw in coords[u].windows(2) {
            let corner = |di: usize, dj: usize| {
                let mut c = [0u32; 3];
                if let Some((d, k)) = layer {
                    c[d] = k;
                }
                c[u] = iw[di];
                c[w] = jw[dj];
                c
            };
            quads.push([corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]);
        }
    }
}
