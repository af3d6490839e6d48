//! The checks of a mesh body (and of pin regions, which grids have too): the file's triangles
//! usable in f32 where the body is, its edges manifold where bending or a lattice needs it, a
//! lattice only in a closed surface, pins that name vertices and groups that exist.

use glam::Vec3;

use super::format_body::{Body, Fill, PinRegion};
use super::rules::{
    Check, F32_EPSILON, MAX_MASSES, MIN_SPRING_ULPS, fail, finite3, positive, springs, start_speed,
    within_reach,
};
use crate::mesh::{Edges, Lattice, TriMesh};

/// A region is a box or a ball, and nothing in between.
pub(super) fn region(f: &str, r: &PinRegion) -> Check {
    match (r.min_m, r.max_m, r.center_m, r.radius_m) {
        (Some(lo), Some(hi), None, None) => {
            finite3(&format!("{f}.min_m"), lo)?;
            finite3(&format!("{f}.max_m"), hi)?;
            if let Some(a) = (0..3).find(|&a| lo[a] > hi[a]) {
                return fail(
                    format!("{f}.max_m[{a}]"),
                    format!(
                        "is below min_m[{a}] ({} < {}): the box is empty",
                        hi[a], lo[a]
                    ),
                );
            }
            Ok(())
        }
        (None, None, Some(c), Some(radius)) => {
            finite3(&format!("{f}.center_m"), c)?;
            positive(&format!("{f}.radius_m"), f64::from(radius))
        }
        _ => fail(
            f,
            "a pin region is a box, `{ min_m = [x, y, z], max_m = [x, y, z] }`, or a ball, \
             `{ center_m = [x, y, z], radius_m = r }`",
        ),
    }
}

/// Every pin region holds at least one of `masses` (where the body's masses start).
pub(super) fn regions_hold_masses(f: &str, b: &Body, masses: &[Vec3]) -> Check {
    for (r, region) in b.pins_in.iter().enumerate() {
        if !masses.iter().any(|p| region.contains(*p)) {
            let (lo, hi) = bounds(masses);
            return fail(
                format!("{f}.pins_in[{r}]"),
                format!(
                    "holds none of the masses of body '{}', which start between {:?} and {:?} m",
                    b.name,
                    lo.to_array(),
                    hi.to_array()
                ),
            );
        }
    }
    Ok(())
}

/// A grid body leaves the mesh's fields alone.
pub(super) fn no_mesh_fields(f: &str, b: &Body) -> Check {
    let only = |field: &str| {
        fail(
            format!("{f}.{field}"),
            format!(
                "is for mesh bodies (`mesh = \"…\"`): remove it from grid body '{}'",
                b.name
            ),
        )
    };
    if b.scale != 1.0 {
        return only("scale");
    }
    if b.rotation_deg != [0.0; 3] {
        return only("rotation_deg");
    }
    if b.fill != Fill::None {
        return only("fill");
    }
    if !b.pin_groups.is_empty() {
        return only("pin_groups");
    }
    Ok(())
}

pub(super) fn mesh_body(f: &str, b: &Body) -> Check {
    let file = b.mesh.as_deref().unwrap_or_default();
    let Some(mesh) = b.surface.as_deref() else {
        return fail(
            format!("{f}.mesh"),
            format!("'{file}' was not read: load the scene with scene::load or scene::from_toml"),
        );
    };
    let fm = format!("{f}.mesh");
    if b.axes.is_some() {
        return fail(
            format!("{f}.axes"),
            "is for grid bodies: turn a mesh with `rotation_deg = [x, y, z]`",
        );
    }
    positive(&format!("{f}.mass_kg"), f64::from(b.mass_kg))?;
    finite3(&format!("{f}.origin_m"), b.origin_m)?;
    finite3(&format!("{f}.velocity_m_per_s"), b.velocity_m_per_s)?;
    start_speed(f, b)?;
    positive(&format!("{f}.scale"), f64::from(b.scale))?;
    finite3(&format!("{f}.rotation_deg"), b.rotation_deg)?;
    springs(f, b)?;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0] {
            return fail(
                fm,
                format!(
                    "mesh '{file}': triangle {t} has two corners at one point (vertices {tri:?} \
                     after joining vertices at equal positions); remove it from the mesh"
                ),
            );
        }
    }
    pins(f, b, mesh, file)?;
    let edges = Edges::of(&mesh.triangles);
    let lattice = b.fill == Fill::Lattice;
    if let Some(e) = edges.non_manifold()
        && (lattice || b.springs.bending.is_some())
    {
        let x = |v: u32| mesh.positions[v as usize].to_array();
        return fail(
            fm,
            format!(
                "mesh '{file}': the edge between vertices {} {:?} and {} {:?} is shared by {} \
                 triangles; {} needs at most two per edge (a manifold surface): mend the mesh, \
                 or {}",
                e.a,
                x(e.a),
                e.b,
                x(e.b),
                e.faces,
                if lattice {
                    "a lattice fill"
                } else {
                    "a bending spring across an edge"
                },
                if lattice {
                    "use fill = \"none\""
                } else {
                    "remove springs.bending"
                },
            ),
        );
    }
    let x = b.placed_vertices();
    let far = x.iter().map(|p| p.as_dvec3().length()).fold(0.0, f64::max);
    within_reach(
        &format!("{f}.scale"),
        if far.is_nan() { f64::INFINITY } else { far },
        &format!(
            "mesh '{file}' at this scale and origin_m is too large; scale it down (is it in millimetres or metres?)"
        ),
    )?;
    resolution(f, b, mesh, &x, file)?;
    match b.fill {
        Fill::None => {
            if b.spacing_m.is_some() {
                return fail(
                    format!("{f}.spacing_m"),
                    "a mesh's springs are its edges: spacing_m is for grids and for `fill = \"lattice\"`; remove it",
                );
            }
            if b.springs.shear.is_some() && mesh.quads.is_empty() {
                return fail(
                    format!("{f}.springs.shear"),
                    format!(
                        "mesh '{file}' has no four-sided faces, whose diagonals shear springs \
                         join (its triangles' edges are already structural springs): remove \
                         springs.shear"
                    ),
                );
            }
            regions_hold_masses(f, b, &x)
        }
        Fill::Lattice => lattice_fill(f, b, mesh, &x, &edges, file),
    }
}

fn lattice_fill(f: &str, b: &Body, mesh: &TriMesh, x: &[Vec3], edges: &Edges, file: &str) -> Check {
    let Some(spacing) = b.spacing_m else {
        return fail(
            format!("{f}.spacing_m"),
            "is missing: `fill = \"lattice\"` needs the lattice's spacing, e.g. a tenth of the mesh's size",
        );
    };
    positive(&format!("{f}.spacing_m"), f64::from(spacing))?;
    if let Some(e) = edges.border() {
        return fail(
            format!("{f}.fill"),
            format!(
                "mesh '{file}' is not closed (the edge between vertices {} and {} has one \
                 triangle): a lattice fills a closed surface only; close the mesh, or use \
                 fill = \"none\" for cloth",
                e.a, e.b
            ),
        );
    }
    let bound = b.mass_count_bound();
    if bound > MAX_MASSES {
        return fail(
            format!("{f}.spacing_m"),
            format!(
                "{spacing} m would fill mesh '{file}' with up to {bound} masses, more than the \
                 limit of {MAX_MASSES}: use a larger spacing_m"
            ),
        );
    }
    let far = x.iter().map(|p| p.as_dvec3().length()).fold(0.0, f64::max) + f64::from(spacing);
    let least = MIN_SPRING_ULPS * far * F32_EPSILON;
    if f64::from(spacing) < least {
        return fail(
            format!("{f}.spacing_m"),
            format!(
                "{spacing:e} m is too small for f32 where the body is (up to {far:.3} m from the \
                 origin): its springs would span fewer than {MIN_SPRING_ULPS} f32 steps; use \
                 {least:.2e} m or more"
            ),
        );
    }
    if b.pins_in.is_empty() {
        return Ok(());
    }
    let lat = Lattice::fill(x, &mesh.triangles, spacing);
    let nodes: Vec<Vec3> = (0..lat.nodes.nodes.len() as u32)
        .map(|v| lat.nodes.position(v))
        .collect();
    regions_hold_masses(f, b, &nodes)
}

/// Vertex pins name vertices; pinned groups exist.
fn pins(f: &str, b: &Body, mesh: &TriMesh, file: &str) -> Check {
    let n = mesh.vertex_count();
    for (p, pin) in b.pins.iter().enumerate() {
        let fp = format!("{f}.pins[{p}]");
        match pin.as_slice() {
            [v] if (*v as usize) < n => {}
            [v] => {
                return fail(
                    format!("{fp}[0]"),
                    format!(
                        "vertex {v} is not in mesh '{file}', whose vertices are 0 to {}",
                        n - 1
                    ),
                );
            }
            _ => {
                return fail(
                    fp,
                    format!(
                        "a mesh body's pin is one vertex index, `[v]`; got {} entries",
                        pin.len()
                    ),
                );
            }
        }
    }
    for (g, name) in b.pin_groups.iter().enumerate() {
        if mesh.group(name).is_none() {
            let known: Vec<&str> = mesh.groups.iter().map(|(n, _)| n.as_str()).collect();
            return fail(
                format!("{f}.pin_groups[{g}]"),
                format!(
                    "mesh '{file}' has no group named '{name}'; {}",
                    if known.is_empty() {
                        "it has no named groups (pin by vertex or with pins_in)".to_owned()
                    } else {
                        format!("its groups are {}", known.join(", "))
                    }
                ),
            );
        }
    }
    Ok(())
}

/// Every triangle's edges and height span enough f32 steps where the body is for its springs'
/// strain to be more than rounding noise (the rule grids follow, `MIN_SPRING_ULPS`).
fn resolution(f: &str, b: &Body, mesh: &TriMesh, x: &[Vec3], file: &str) -> Check {
    let far = x.iter().map(|p| p.as_dvec3().length()).fold(0.0, f64::max);
    let least = MIN_SPRING_ULPS * far * F32_EPSILON;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [p, q, r] = tri.map(|v| x[v as usize].as_dvec3());
        let sides = [(q - p).length(), (r - q).length(), (p - r).length()];
        let longest = sides.iter().copied().fold(0.0, f64::max);
        let shortest = sides.iter().copied().fold(f64::INFINITY, f64::min);
        let height = (q - p).cross(r - p).length() / longest.max(f64::MIN_POSITIVE);
        if shortest.min(height) < least {
            return fail(
                format!("{f}.mesh"),
                format!(
                    "mesh '{file}': triangle {t} (vertices {tri:?}) is degenerate in f32 where \
                     body '{}' is: its shortest side is {shortest:.2e} m and its height \
                     {height:.2e} m, but positions up to {far:.3} m from the origin need \
                     {least:.2e} m ({MIN_SPRING_ULPS} f32 steps) for a spring's strain to be more \
                     than rounding; remove the sliver, or raise `scale`",
                    b.name
                ),
            );
        }
    }
    Ok(())
}

fn bounds(x: &[Vec3]) -> (Vec3, Vec3) {
    x.iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        })
}
