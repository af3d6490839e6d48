//! Semantic checks on one body of a parsed scene: a grid's counts, spacing, placement and
//! springs, or a mesh's fields; its pins. Each failure names the field path and says what is
//! allowed.

use super::format_body::Body;
use super::mesh_checks;
use super::rules::{
    Check, F32_EPSILON, MAX_MASSES, MIN_SPRING_ULPS, fail, finite3, positive, springs, start_speed,
    within_reach,
};

pub(super) fn body(f: &str, b: &Body) -> Check {
    if b.name.trim().is_empty() {
        return fail(format!("{f}.name"), "must not be empty");
    }
    for (r, region) in b.pins_in.iter().enumerate() {
        mesh_checks::region(&format!("{f}.pins_in[{r}]"), region)?;
    }
    match (b.grid.is_empty(), &b.mesh) {
        (false, Some(_)) => fail(
            format!("{f}.mesh"),
            "a body is a grid or a mesh, not both: remove `grid` or `mesh`",
        ),
        (true, None) => fail(
            format!("{f}.grid"),
            "a body needs a grid of 1, 2 or 3 counts (a strand, sheet or block: `grid = [20, 20]`) or a mesh file (`mesh = \"flag.obj\"`)",
        ),
        (true, Some(_)) => mesh_checks::mesh_body(f, b),
        (false, None) => {
            mesh_checks::no_mesh_fields(f, b)?;
            grid_body(f, b)
        }
    }
}

fn grid_body(f: &str, b: &Body) -> Check {
    let Some(spacing) = b.spacing_m else {
        return fail(
            format!("{f}.spacing_m"),
            "is missing: a grid body needs the distance between grid neighbours, e.g. `spacing_m = 0.02`",
        );
    };
    let dim = b.grid.len();
    if !(1..=3).contains(&dim) {
        return fail(
            format!("{f}.grid"),
            format!("must list 1, 2 or 3 counts (a strand, sheet or block), got {dim}"),
        );
    }
    for (a, &n) in b.grid.iter().enumerate() {
        if n == 0 {
            return fail(
                format!("{f}.grid[{a}]"),
                "the grid is empty: every count must be at least 1",
            );
        }
    }
    let count: u64 = b.grid.iter().map(|&n| u64::from(n)).product();
    if count > MAX_MASSES {
        return fail(
            format!("{f}.grid"),
            format!("{count} masses is more than the limit of {MAX_MASSES}"),
        );
    }
    placement(f, b, spacing)?;
    pins(f, b)?;
    springs(f, b)?;
    if dim == 1 && b.springs.shear.is_some() {
        return fail(
            format!("{f}.springs.shear"),
            "shear springs join diagonal neighbours and need a 2D or 3D grid; remove them for a strand",
        );
    }
    geometry(f, b, spacing)?;
    mesh_checks::regions_hold_masses(f, b, &grid_positions(b, spacing))
}

/// Where a grid body's masses start.
fn grid_positions(b: &Body, spacing: f32) -> Vec<glam::Vec3> {
    if b.pins_in.is_empty() {
        return Vec::new();
    }
    let n = [0, 1, 2].map(|a| b.grid.get(a).copied().unwrap_or(1));
    let axes: Vec<glam::Vec3> = match &b.axes {
        Some(a) => a.iter().map(|v| glam::Vec3::from(*v).normalize()).collect(),
        None => [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z][..b.grid.len()].to_vec(),
    };
    let axis = |a: usize| axes.get(a).copied().unwrap_or(glam::Vec3::ZERO);
    let origin = glam::Vec3::from(b.origin_m);
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                out.push(
                    origin
                        + spacing * (i as f32 * axis(0) + j as f32 * axis(1) + k as f32 * axis(2)),
                );
            }
        }
    }
    out
}

/// Spacing, mass, where the body starts and how its grid is laid out.
fn placement(f: &str, b: &Body, spacing: f32) -> Check {
    let dim = b.grid.len();
    positive(&format!("{f}.spacing_m"), f64::from(spacing))?;
    positive(&format!("{f}.mass_kg"), f64::from(b.mass_kg))?;
    finite3(&format!("{f}.origin_m"), b.origin_m)?;
    finite3(&format!("{f}.velocity_m_per_s"), b.velocity_m_per_s)?;
    start_speed(f, b)?;
    if let Some(axes) = &b.axes {
        if axes.len() != dim {
            return fail(
                format!("{f}.axes"),
                format!(
                    "needs one direction per grid axis ({dim}), got {}",
                    axes.len()
                ),
            );
        }
        for (a, v) in axes.iter().enumerate() {
            let fa = format!("{f}.axes[{a}]");
            finite3(&fa, *v)?;
            if glam::Vec3::from(*v).length() < 1e-6 {
                return fail(fa, "must be a non-zero direction");
            }
        }
    }
    Ok(())
}

fn pins(f: &str, b: &Body) -> Check {
    let dim = b.grid.len();
    for (p, pin) in b.pins.iter().enumerate() {
        let fp = format!("{f}.pins[{p}]");
        if pin.len() != dim {
            return fail(
                fp,
                format!(
                    "a pin is a grid index with {dim} entries, like the grid; got {}",
                    pin.len()
                ),
            );
        }
        for (a, (&idx, &n)) in pin.iter().zip(&b.grid).enumerate() {
            if idx >= n {
                return fail(
                    format!("{fp}[{a}]"),
                    format!(
                        "pin index {idx} is outside the grid: axis {a} has indices 0 to {}",
                        n - 1
                    ),
                );
            }
        }
    }
    Ok(())
}

/// The grid's masses must be distinct points and its springs long enough for f32 to resolve
/// their strain where the body is: coordinates far from the origin are coarser in f32, so a
/// small spacing that is fine at the origin collapses at 0.5 m.
fn geometry(f: &str, b: &Body, spacing: f32) -> Check {
    let dim = b.grid.len();
    let axes = independent_axes(f, b)?;
    let s = f64::from(spacing);
    let reach: f64 = b.grid.iter().map(|&n| f64::from(n.saturating_sub(1))).sum();
    let origin = glam::Vec3::from(b.origin_m).as_dvec3().length();
    // The farthest a mass lies from the origin at the start, and one ulp there.
    let far = origin + s * reach;
    within_reach(
        &format!("{f}.spacing_m"),
        far,
        "use a smaller spacing_m or fewer masses, and an origin_m nearer to [0, 0, 0]",
    )?;
    let ulp = far * F32_EPSILON;
    let kinds = [
        (
            crate::laws::spring_kind::SpringKindTag::Structural,
            b.springs.structural,
        ),
        (
            crate::laws::spring_kind::SpringKindTag::Shear,
            b.springs.shear,
        ),
        (
            crate::laws::spring_kind::SpringKindTag::Bending,
            b.springs.bending,
        ),
    ];
    for (tag, params) in kinds {
        if params.is_none() {
            continue;
        }
        for off in crate::laws::spring_kind::kind_offsets(tag) {
            if off.iter().enumerate().any(|(a, &o)| {
                o != 0 && (a >= dim || u32::try_from(o.abs()).is_ok_and(|o| o >= b.grid[a]))
            }) {
                continue;
            }
            // Rest length in units of the spacing.
            let g = off
                .iter()
                .zip(&axes)
                .map(|(&o, a)| f64::from(o) * *a)
                .sum::<glam::DVec3>()
                .length();
            let length = s * g;
            if length >= MIN_SPRING_ULPS * ulp {
                continue;
            }
            // Solve s · g ≥ K ε (|origin| + s · reach) for the smallest usable spacing.
            let k = MIN_SPRING_ULPS * F32_EPSILON;
            let room = g - k * reach;
            let fix = if room > 0.0 {
                format!(
                    "the smallest usable spacing_m here is {:.2e} m; or move origin_m nearer to \
                     [0, 0, 0]",
                    k * origin / room
                )
            } else {
                "no spacing works for a grid this large in f32: use fewer masses".to_owned()
            };
            return fail(
                format!("{f}.spacing_m"),
                format!(
                    "body '{}': {s:e} m is too small for f32 where the body is: its masses lie up \
                     to {far:.3} m from the origin, where f32 positions are {ulp:.2e} m apart, so \
                     its {} springs ({length:.2e} m long) would span fewer than {MIN_SPRING_ULPS} \
                     of those steps and their strain would be rounding noise; {fix}",
                    b.name,
                    tag.name(),
                ),
            );
        }
    }
    Ok(())
}

/// The body's grid axes as unit vectors, refused when they span no area (volume): grid points
/// would then lie on top of each other.
fn independent_axes(f: &str, b: &Body) -> Result<Vec<glam::DVec3>, (String, String)> {
    let dim = b.grid.len();
    let axes: Vec<glam::DVec3> = match &b.axes {
        Some(a) => a
            .iter()
            .map(|v| glam::Vec3::from(*v).as_dvec3().normalize())
            .collect(),
        None => [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z][..dim].to_vec(),
    };
    // Axes that span no area (volume) put grid points on top of each other.
    let span = match dim {
        2 => axes[0].cross(axes[1]).length(),
        3 => axes[0].cross(axes[1]).dot(axes[2]).abs(),
        _ => 1.0,
    };
    if span < 1e-3 {
        return fail(
            format!("{f}.axes"),
            format!(
                "body '{}': the axes are (nearly) {}, so masses of the grid lie on top of each \
                 other and the springs between them have no length; give independent directions",
                b.name,
                if dim == 2 { "parallel" } else { "in one plane" }
            ),
        );
    }
    Ok(axes)
}
