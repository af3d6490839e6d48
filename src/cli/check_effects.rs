//! `hooke check`'s lines on the effects a scene asks for: gravity, drag, contact and each
//! collider, mass–mass contact, plasticity and tearing.

use std::fmt::Write as _;

use hooke::model::{Collider, Model, Path, Shape};

/// Every effect the scene has, with its parameters; "none" when it has none.
pub(super) fn effects(s: &mut String, model: &Model) {
    let e = &model.effects;
    let _ = writeln!(s, "  effects:");
    let mut any = false;
    if let Some(g) = e.gravity_m_per_s2 {
        let _ = writeln!(s, "    gravity {:?} m/s²", g.to_array());
        any = true;
    }
    if let Some(d) = e.air_drag_per_s {
        let _ = writeln!(s, "    air drag {d} /s");
        any = true;
    }
    if let Some(g) = &e.ground {
        let _ = writeln!(
            s,
            "    ground at y = {} m: stiffness {} N/m, friction {}, damping ratio {:.3}",
            g.height_m, g.contact.stiffness_n_per_m, g.contact.friction, g.contact.damping_ratio
        );
        any = true;
    }
    let mut counts = std::collections::HashMap::new();
    for c in &e.colliders {
        let i = counts.entry(c.kind()).or_insert(0usize);
        *i += 1;
        let _ = writeln!(s, "{}", collider(c, *i - 1));
        any = true;
    }
    for b in &model.bodies {
        let Some(l) = model.limits.get(b.springs.start as usize) else {
            continue;
        };
        if l.yield_strain.is_finite() {
            let _ = writeln!(
                s,
                "    plasticity of '{}': yield strain {}, creep {} /s",
                b.name, l.yield_strain, l.creep_per_s
            );
            any = true;
        }
        if l.break_strain.is_finite() {
            let _ = writeln!(
                s,
                "    tearing of '{}': springs break past strain {}",
                b.name, l.break_strain
            );
            any = true;
        }
    }
    if let Some(c) = &e.self_collision {
        let _ = writeln!(
            s,
            "    self-collision ({}): radius {} m, stiffness {} N/m per pair, friction {}, damping ratio {:.3} (with the pair's reduced mass); neighbour lists of the masses within {:.4} m, rebuilt once a mass has moved {:.4} m, through a hash grid of {} buckets",
            if c.within_bodies {
                "within and between bodies"
            } else {
                "between bodies only"
            },
            c.radius_m,
            c.contact.stiffness_n_per_m,
            c.contact.friction,
            c.contact.damping_ratio,
            hooke::physics::neighbour_reach_m(c.radius_m),
            hooke::physics::neighbour_moved_limit_m(c.radius_m),
            hooke::physics::table_size(model.mass_count())
        );
        any = true;
    }
    if !any {
        let _ = writeln!(s, "    none");
    }
}

/// One collider: its shape, its path and its contact.
fn collider(c: &Collider, i: usize) -> String {
    let shape = match c.shape {
        Shape::Sphere { radius_m } => format!("radius {radius_m} m"),
        Shape::Box { half_extents_m } => {
            format!("half extents {:?} m", half_extents_m.to_array())
        }
        Shape::Plane { normal } => format!("normal {:?}", normal.to_array()),
    };
    let path = match &c.path {
        Path::Linear { start_m, .. } if c.path.is_fixed() => {
            format!("fixed at {:?} m", start_m.to_array())
        }
        Path::Linear {
            start_m,
            velocity_m_per_s,
        } => format!(
            "from {:?} m at {:?} m/s",
            start_m.to_array(),
            velocity_m_per_s.to_array()
        ),
        Path::Keyframes(keys) => format!(
            "on {} keyframes from {:.3} s to {:.3} s",
            keys.len(),
            keys.first().map_or(0.0, |k| k.0),
            keys.last().map_or(0.0, |k| k.0)
        ),
    };
    format!(
        "    {} {i}: {shape}, {path}, stiffness {} N/m, friction {}, damping ratio {:.3}",
        c.kind(),
        c.contact.stiffness_n_per_m,
        c.contact.friction,
        c.contact.damping_ratio
    )
}
