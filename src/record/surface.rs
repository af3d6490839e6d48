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
/// face, and whether it is two-sided (a sheet); `None` for a strand.
fn surface_quads(n: [u32; 3], axes: &[(usize, u32)]) -> Option<(Vec<[[u32; 3]; 4]>, bool)> {
    let mut quads: Vec<[[u32; 3]; 4]> = Vec::new();
    let two_sided = match axes.len() {
        2 => {
            let (u, w) = (axes[0].0, axes[1].0);
            push_face(&mut quads, n, u, w, None);
            true
        }
        3 => {
            // Six faces: for each axis d, the layer at index 0 and at n[d] − 1.
            for (d, u, w) in [(2, 0, 1), (0, 1, 2), (1, 2, 0)] {
                push_face(&mut quads, n, u, w, Some((d, 0)));
                push_face(&mut quads, n, u, w, Some((d, n[d] - 1)));
            }
            false
        }
        _ => return None,
    };
    Some((quads, two_sided))
}

impl Surface {
    /// The body's surface, or `None` for a strand (fewer than two grid axes with extent).
    pub fn of_body(model: &Model, body: &BodyInfo) -> Option<Self> {
        let grid = match &body.shape {
            BodyShape::Grid(g) => g,
            BodyShape::Mesh(m) => return Some(Self::of_mesh(model, body, m)),
        };
        let axes = grid_axes(grid);
        let n = [0, 1, 2].map(|a| grid.get(a).copied().unwrap_or(1));
        let stride = [1, n[0], n[0] * n[1]];
        let base = body.masses.start;
        let mass_at = |c: [u32; 3]| base + c[0] * stride[0] + c[1] * stride[1] + c[2] * stride[2];
        let (quads, two_sided) = surface_quads(n, &axes)?;
        // Vertices: every mass that a quad touches, in mass order.
        let mut used: Vec<u32> = quads.iter().flatten().map(|c| mass_at(*c)).collect();
        used.sort_unstable();
        used.dedup();
        let vertex_of: HashMap<u32, u32> = used
            .iter()
            .enumerate()
            .map(|(v, m)| (*m, v as u32))
            .collect();
        let spring_of = springs_by_ends(model, body);
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
        Some(Self {
            vertex_mass: used,
            triangles,
            edge_springs,
            two_sided,
            can_tear,
            embedding: None,
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
                }
            }
            MeshVertices::Embedded(embedded) => Self {
                vertex_mass: embedded.iter().map(|e| e.nearest()).collect(),
                triangles: mesh.triangles.clone(),
                edge_springs: vec![[NO_SPRING; 3]; mesh.triangles.len()],
                two_sided,
                can_tear: false,
                embedding: Some(embedded.clone()),
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

/// Quads of one grid face spanned by axes `u` and `w`, at `layer = (axis, index)` for a block's
/// face or across the whole (2D) grid.
fn push_face(
    quads: &mut Vec<[[u32; 3]; 4]>,
    n: [u32; 3],
    u: usize,
    w: usize,
    layer: Option<(usize, u32)>,
) {
    for j in 0..n[w].saturating_sub(1) {
        for i in 0..n[u].saturating_sub(1) {
            let corner = |di: u32, dj: u32| {
                let mut c = [0u32; 3];
                if let Some((d, k)) = layer {
                    c[d] = k;
                }
                c[u] = i + di;
                c[w] = j + dj;
                c
            };
            quads.push([corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]);
        }
    }
}

/// The signed strain of the most strained intact structural spring at each mass of
/// `vertex_mass` (largest |strain|; every kind counts where the model has no structural spring;
/// 0 where none is intact), written into `out`.
pub fn vertex_strain(model: &Model, strain: &[f32], vertex_mass: &[u32], out: &mut Vec<f32>) {
    let any_structural = model.spring_kind.contains(&SpringKindTag::Structural);
    out.clear();
    out.extend(vertex_mass.iter().map(|&m| {
        model
            .adjacency
            .of(m as usize)
            .iter()
            .filter(|nb| {
                !any_structural
                    || model.spring_kind[nb.spring as usize] == SpringKindTag::Structural
            })
            .map(|nb| strain[nb.spring as usize])
            .filter(|s| !s.is_nan())
            .fold(
                0.0f32,
                |best, s| if s.abs() > best.abs() { s } else { best },
            )
    }));
}

/// Area-weighted vertex normals of `triangles` (unit length; zero where a vertex has none).
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]], out: &mut Vec<Vec3>) {
    out.clear();
    out.resize(positions.len(), Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        // |cross| is twice the area: larger triangles weigh more.
        let n = (b - a).cross(c - a);
        for v in t {
            out[*v as usize] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.normalize_or_zero();
    }
}

/// The viewer's mesh lighting (Rerun 0.36, `simple_lighting` in re_renderer's shaders): an
/// ambient 0.2, a key light along (1, 2, 3) and a fill light at half strength along
/// (−1, −3, −5), fixed in the world. A sheet is lit on whichever side faces the key light, as a
/// double-sided surface is; a zero normal (a vertex with no triangle) is left unlit.
pub fn shade(normal: Vec3, two_sided: bool) -> f32 {
    if normal == Vec3::ZERO {
        return 1.0;
    }
    let key = Vec3::new(1.0, 2.0, 3.0).normalize();
    let fill = Vec3::new(-1.0, -3.0, -5.0).normalize();
    let n = if two_sided && normal.dot(key) < 0.0 {
        -normal
    } else {
        normal
    };
    (0.2 + n.dot(key).max(0.0) + 0.5 * n.dot(fill).max(0.0)).clamp(0.0, 1.0)
}

/// An sRGB colour lit by `shade` as the viewer lights it: in linear light, then back to sRGB
/// (through lookup tables, within one level of 255 of the exact conversion: a frame of
/// cloth-256 shades 65 536 vertices).
pub fn shaded(srgb: [u8; 3], shade: f32) -> [u8; 3] {
    let t = tables();
    srgb.map(|c| {
        let lin = t.to_linear[usize::from(c)] * shade.clamp(0.0, 1.0);
        t.to_srgb[(lin * (SRGB_STEPS - 1) as f32).round() as usize]
    })
}

const SRGB_STEPS: usize = 4096;

struct Tables {
    to_linear: [f32; 256],
    to_srgb: Vec<u8>,
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| Tables {
        to_linear: std::array::from_fn(|c| linear_from_srgb(c as f32 / 255.0)),
        to_srgb: (0..SRGB_STEPS)
            .map(|i| {
                let lin = i as f32 / (SRGB_STEPS - 1) as f32;
                (srgb_from_linear(lin) * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect(),
    })
}

fn linear_from_srgb(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn srgb_from_linear(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shading_is_full_towards_the_key_light_and_ambient_away_from_both() {
        let key = Vec3::new(1.0, 2.0, 3.0).normalize();
        assert_eq!(shade(key, false), 1.0);
        // Perpendicular to both lights: ambient only.
        let away = Vec3::new(1.0, 2.0, 3.0).cross(Vec3::new(-1.0, -3.0, -5.0));
        assert!((shade(away.normalize(), false) - 0.2).abs() < 1e-5);
        // A sheet's back is lit as its front; a block's is not.
        assert_eq!(shade(-key, true), 1.0);
        assert!(shade(-key, false) < 0.7);
    }

    #[test]
    fn shaded_keeps_a_colour_at_full_light_and_darkens_it_in_shadow() {
        assert_eq!(shaded([180, 4, 38], 1.0), [180, 4, 38]);
        let dark = shaded([221, 221, 221], 0.2);
        assert!(dark[0] < 221 && dark[0] == dark[1] && dark[1] == dark[2]);
        assert_eq!(shaded([0, 0, 0], 0.5), [0, 0, 0]);
    }
}
