//! A mesh body's masses and springs. An open surface (or `fill = "none"`) is cloth: a mass per
//! vertex, lumped from the areas of its triangles, a structural spring per edge, a bending
//! spring across each interior edge (between the two corners opposite it) and, where the file
//! had quads, shear springs on both their diagonals. `fill = "lattice"` fills a closed surface
//! with a jello lattice whose cells carry the surface's vertices.
//!
//! Masses are numbered along a space-filling curve (Morton order of their positions), so that a
//! mass's neighbours sit near it in memory on an irregular mesh as on a grid.

use std::collections::HashSet;
use std::sync::Arc;

use glam::Vec3;

use crate::laws::spring_kind::{SpringKindTag, kind_offsets};
use crate::mesh::{Edges, Lattice, TriMesh, morton_order};
use crate::scene::{self, Fill, SpringKind};

use super::builder::ModelBuilder;
use super::system::{BodyShape, MeshShape, MeshVertices};

/// Add the body's masses and springs; its shape, for the recording.
pub(super) fn add(mb: &mut ModelBuilder, body: &scene::Body, mesh: &TriMesh) -> BodyShape {
    let x = body.placed_vertices();
    let file = body.mesh.clone().unwrap_or_default();
    let shape = match body.fill {
        Fill::None => cloth(mb, body, mesh, &x, file),
        Fill::Lattice => lattice(mb, body, mesh, &x, file),
    };
    BodyShape::Mesh(Arc::new(shape))
}

/// Vertices pinned by index or by group (those refused by validation pin nothing).
fn pinned_vertices(body: &scene::Body, mesh: &TriMesh) -> Vec<u32> {
    let mut out: Vec<u32> = body
        .pins
        .iter()
        .filter_map(|p| p.first().copied())
        .collect();
    for g in &body.pin_groups {
        out.extend(mesh.group(g).unwrap_or_default());
    }
    out.retain(|&v| (v as usize) < mesh.vertex_count());
    out
}

fn cloth(
    mb: &mut ModelBuilder,
    body: &scene::Body,
    mesh: &TriMesh,
    x: &[Vec3],
    file: String,
) -> MeshShape {
    let n = x.len();
    let order = morton_order(x);
    let mut new_of = vec![0u32; n];
    for (new, &old) in order.iter().enumerate() {
        new_of[old as usize] = new as u32;
    }
    // Each triangle gives a third of its area to each corner; mass follows area.
    let mut share = vec![0f64; n];
    for (t, a) in mesh.triangles.iter().zip(mesh.areas(x)) {
        for v in t {
            share[*v as usize] += a / 3.0;
        }
    }
    let total: f64 = share.iter().sum();
    let mut pinned = vec![false; n];
    for v in pinned_vertices(body, mesh) {
        pinned[v as usize] = true;
    }
    for (v, p) in x.iter().enumerate() {
        pinned[v] |= body.pins_in.iter().any(|r| r.contains(*p));
    }
    let base = mb.mass_count();
    let vel = Vec3::from(body.velocity_m_per_s);
    for &old in &order {
        let o = old as usize;
        let m = (f64::from(body.mass_kg) * share[o] / total) as f32;
        mb.mass(x[o], vel, m, pinned[o]);
    }
    let mass = |old: u32| base + new_of[old as usize];
    let mut joined: HashSet<(u32, u32)> = HashSet::new();
    let mut spring = |mb: &mut ModelBuilder, a: u32, b: u32, k: SpringKind, tag| {
        let (a, b) = (mass(a), mass(b));
        if a != b && joined.insert((a.min(b), a.max(b))) {
            let rest = mb.position(a).distance(mb.position(b));
            mb.spring_with_rest(a, b, rest, k.stiffness_n_per_m, k.damping_n_s_per_m, tag);
        }
    };
    let s = &body.springs;
    let diagonals: HashSet<(u32, u32)> = mesh
        .quads
        .iter()
        .flat_map(|q| [(q[0], q[2]), (q[1], q[3])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    let edges = Edges::of(&mesh.triangles);
    // Shear first where asked: a quad's diagonals are shear springs, not structural ones.
    if let Some(k) = s.shear {
        for &(a, b) in &diagonals {
            spring(mb, a, b, k, SpringKindTag::Shear);
        }
    }
    if let Some(k) = s.structural {
        for e in &edges.edges {
            spring(mb, e.a, e.b, k, SpringKindTag::Structural);
        }
    }
    if let Some(k) = s.bending {
        for e in edges.interior() {
            if !diagonals.contains(&(e.a, e.b)) {
                spring(mb, e.opposite[0], e.opposite[1], k, SpringKindTag::Bending);
            }
        }
    }
    MeshShape {
        file,
        triangles: mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| new_of[v as usize]))
            .collect(),
        vertices: MeshVertices::Masses((0..n as u32).map(|v| base + v).collect()),
        closed: edges.border().is_none(),
    }
}

fn lattice(
    mb: &mut ModelBuilder,
    body: &scene::Body,
    mesh: &TriMesh,
    x: &[Vec3],
    file: String,
) -> MeshShape {
    let spacing = body.spacing_m.unwrap_or_default();
    let lat = Lattice::fill(x, &mesh.triangles, spacing);
    let nodes = &lat.nodes;
    let count = nodes.nodes.len();
    let mut pinned = vec![false; count];
    // A pinned vertex holds its cell: the eight corners it follows.
    for v in pinned_vertices(body, mesh) {
        for c in lat.embedded[v as usize].corners {
            pinned[c as usize] = true;
        }
    }
    let base = mb.mass_count();
    let vel = Vec3::from(body.velocity_m_per_s);
    let m = body.mass_kg / count as f32;
    for (v, pin) in pinned.iter().enumerate() {
        let p = nodes.position(v as u32);
        let pin = *pin || body.pins_in.iter().any(|r| r.contains(p));
        mb.mass(p, vel, m, pin);
    }
    let s = &body.springs;
    for (tag, params) in [
        (SpringKindTag::Structural, s.structural),
        (SpringKindTag::Shear, s.shear),
        (SpringKindTag::Bending, s.bending),
    ] {
        let Some(k) = params else { continue };
        for off in kind_offsets(tag) {
            for v in 0..count as u32 {
                if let Some(q) = nodes.joined(v, *off) {
                    let (a, b) = (base + v, base + q);
                    let rest = mb.position(a).distance(mb.position(b));
                    mb.spring_with_rest(a, b, rest, k.stiffness_n_per_m, k.damping_n_s_per_m, tag);
                }
            }
        }
    }
    let embedded = lat
        .embedded
        .iter()
        .map(|e| crate::mesh::Embedded {
            corners: e.corners.map(|c| base + c),
            weights: e.weights,
        })
        .collect();
    MeshShape {
        file,
        triangles: mesh.triangles.clone(),
        vertices: MeshVertices::Embedded(embedded),
        closed: true,
    }
}
