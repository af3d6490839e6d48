//! Semantic checks on a parsed scene. Each failure names the field path and says what is allowed;
//! [`super::from_toml`] adds the file position.

use super::format::{Keyframe, Scene, SelfCollision};
use super::format_body::Body;
use super::rules::{Check, MAX_MASSES, MOST_SWEEPS, fail, finite, finite3, non_negative, positive};
use super::validate_body::body;

/// Colliders per scene: the GPU passes every collider's pose in each stage's uniform slot.
pub const MAX_COLLIDERS: usize = 16;

/// A collider's path: `center_m` (and `velocity_m_per_s`), or `keyframes`.
fn path(f: &str, center: Option<[f32; 3]>, velocity: [f32; 3], keys: &[Keyframe]) -> Check {
    finite3(&format!("{f}.velocity_m_per_s"), velocity)?;
    if keys.is_empty() {
        return match center {
            Some(c) => finite3(&format!("{f}.center_m"), c),
            None => fail(
                format!("{f}.center_m"),
                "is missing: give the collider a `center_m` (and optionally `velocity_m_per_s`), or `keyframes`",
            ),
        };
    }
    if center.is_some() {
        return fail(
            format!("{f}.keyframes"),
            "a collider on keyframes takes its position from them: remove `center_m`",
        );
    }
    if velocity != [0.0; 3] {
        return fail(
            format!("{f}.keyframes"),
            "a collider on keyframes takes its velocity from them: remove `velocity_m_per_s`",
        );
    }
    for (k, key) in keys.iter().enumerate() {
        finite(&format!("{f}.keyframes[{k}].time_secs"), key.time_secs)?;
        finite3(&format!("{f}.keyframes[{k}].center_m"), key.center_m)?;
        if k > 0 && key.time_secs <= keys[k - 1].time_secs {
            return fail(
                format!("{f}.keyframes[{k}].time_secs"),
                format!(
                    "keyframe times must increase: {} s follows {} s",
                    key.time_secs,
                    keys[k - 1].time_secs
                ),
            );
        }
    }
    Ok(())
}

fn contact(field: &str, stiffness: f32, friction: f32, restitution: f32) -> Check {
    positive(&format!("{field}.stiffness_n_per_m"), f64::from(stiffness))?;
    non_negative(&format!("{field}.friction"), f64::from(friction))?;
    let r = f64::from(restitution);
    finite(&format!("{field}.restitution"), r)?;
    let least = crate::laws::contact_law::MIN_RESTITUTION;
    if !(f64::from(least)..=1.0).contains(&r) {
        return fail(
            format!("{field}.restitution"),
            format!(
                "must lie between {least} (the impact ends at rest on the surface) and 1 (elastic), got {r}"
            ),
        );
    }
    Ok(())
}

pub fn validate(scene: &Scene) -> Check {
    if scene.name.trim().is_empty() {
        return fail("name", "must not be empty");
    }
    solver(&scene.solver)?;
    effects(&scene.effects)?;
    bodies(scene)?;
    if let Some(sc) = &scene.effects.self_collision {
        self_collision(scene, sc)?;
    }
    positive("view.strain_range", f64::from(scene.view.strain_range))?;
    if let Some(c) = &scene.compare {
        compare(scene, c)?;
    }
    Ok(())
}

/// A `[compare]` table: entries that read as entries, whose integrators can simulate the scene.
fn compare(scene: &Scene, c: &super::format::Compare) -> Check {
    if c.entries.is_empty() {
        return fail(
            "compare.entries",
            "must name at least one entry, e.g. entries = [\"rk4\", \"xpbd\", \"implicit@1/60\"]",
        );
    }
    for (i, text) in c.entries.iter().enumerate() {
        let field = format!("compare.entries[{i}]");
        let entry = crate::scene::compare_entry::CompareEntry::parse(text)
            .or_else(|e| fail(&field, e.to_string()))?;
        if let Err(why) = entry.integrator.supports(&scene.effects) {
            return fail(
                field,
                format!("{why} ([{}] in this scene)", why.scene_field()),
            );
        }
    }
    if let Some(g) = c.gap_range_m {
        positive("compare.gap_range_m", f64::from(g))?;
    }
    Ok(())
}

fn solver(s: &super::format::Solver) -> Check {
    positive("solver.frame_rate_hz", s.frame_rate_hz)?;
    if let Some(n) = s.substeps
        && n == 0
    {
        return fail("solver.substeps", "must be at least 1");
    }
    if let Some(dt) = s.dt_secs {
        positive("solver.dt_secs", dt)?;
        if s.substeps.is_some() {
            return fail(
                "solver.dt_secs",
                "give either `substeps` or `dt_secs`, not both: dt = 1 / (frame_rate_hz · substeps)",
            );
        }
    }
    if let Some(d) = s.duration_secs {
        positive("solver.duration_secs", d)?;
        if s.frames.is_some() {
            return fail(
                "solver.frames",
                "give either `frames` or `duration_secs`, not both: frames = duration_secs · frame_rate_hz",
            );
        }
    }
    if s.xpbd_iterations == Some(0) {
        return fail(
            "solver.xpbd_iterations",
            "must be at least 1 (each substep projects every spring that many times)",
        );
    }
    if s.vbd_iterations == Some(0) {
        return fail(
            "solver.vbd_iterations",
            "must be at least 1 (each step sweeps every mass that many times)",
        );
    }
    for (given, field) in [
        (s.xpbd_iterations, "solver.xpbd_iterations"),
        (s.vbd_iterations, "solver.vbd_iterations"),
    ] {
        if given.is_some_and(|n| n > MOST_SWEEPS) {
            return fail(
                field,
                format!(
                    "must be at most {MOST_SWEEPS}: more sweeps make one step too long to stop in time (a converged reference rarely needs more than 10 000)"
                ),
            );
        }
    }
    if s.frames == Some(0) {
        return fail("solver.frames", "must be at least 1");
    }
    Ok(())
}

fn effects(e: &super::format::Effects) -> Check {
    if let Some(g) = e.gravity_m_per_s2 {
        finite3("effects.gravity_m_per_s2", g)?;
    }
    if let Some(d) = e.air_drag_per_s {
        non_negative("effects.air_drag_per_s", f64::from(d))?;
    }
    if let Some(g) = &e.ground {
        finite("effects.ground.height_m", f64::from(g.height_m))?;
        contact(
            "effects.ground",
            g.stiffness_n_per_m,
            g.friction,
            g.restitution,
        )?;
    }
    for (i, sp) in e.spheres.iter().enumerate() {
        let f = format!("effects.spheres[{i}]");
        path(&f, sp.center_m, sp.velocity_m_per_s, &sp.keyframes)?;
        positive(&format!("{f}.radius_m"), f64::from(sp.radius_m))?;
        contact(&f, sp.stiffness_n_per_m, sp.friction, sp.restitution)?;
    }
    for (i, b) in e.boxes.iter().enumerate() {
        let f = format!("effects.boxes[{i}]");
        path(&f, b.center_m, b.velocity_m_per_s, &b.keyframes)?;
        for (a, h) in b.half_extents_m.iter().enumerate() {
            positive(&format!("{f}.half_extents_m[{a}]"), f64::from(*h))?;
        }
        contact(&f, b.stiffness_n_per_m, b.friction, b.restitution)?;
    }
    for (i, p) in e.planes.iter().enumerate() {
        let f = format!("effects.planes[{i}]");
        finite3(&format!("{f}.point_m"), p.point_m)?;
        finite3(&format!("{f}.normal"), p.normal)?;
        if glam::Vec3::from(p.normal).length() < 1e-6 {
            return fail(format!("{f}.normal"), "must be a non-zero direction");
        }
        contact(&f, p.stiffness_n_per_m, p.friction, p.restitution)?;
    }
    let moving = e.spheres.len() + e.boxes.len() + e.planes.len();
    if moving > MAX_COLLIDERS {
        return fail(
            "effects",
            format!(
                "the scene has {moving} sphere, box and plane colliders; at most {MAX_COLLIDERS} are supported"
            ),
        );
    }
    Ok(())
}

/// Each body, then the scene's total of masses.
fn bodies(scene: &Scene) -> Check {
    if scene.bodies.is_empty() {
        return fail("bodies", "a scene needs at least one body ([[bodies]])");
    }
    let mut total: u64 = 0;
    for (i, b) in scene.bodies.iter().enumerate() {
        let f = format!("bodies[{i}]");
        body(&f, b)?;
        if scene.bodies[..i].iter().any(|o| o.name == b.name) {
            return fail(
                format!("{f}.name"),
                format!("another body is already named '{}'", b.name),
            );
        }
        total = total.saturating_add(b.mass_count_bound());
        if total > MAX_MASSES {
            let field = if b.mesh.is_some() { "mesh" } else { "grid" };
            return fail(
                format!("{f}.{field}"),
                format!("the scene would hold {total} masses, more than the limit of {MAX_MASSES}"),
            );
        }
    }
    Ok(())
}

/// A mesh body without a lattice: its masses are its vertices.
fn cloth(b: &Body) -> bool {
    b.mesh.is_some() && b.fill == super::format_body::Fill::None
}

fn self_collision(scene: &Scene, sc: &SelfCollision) -> Check {
    let f = "effects.self_collision";
    positive(&format!("{f}.radius_m"), f64::from(sc.radius_m))?;
    contact(f, sc.stiffness_n_per_m, sc.friction, sc.restitution)?;
    if sc.within_bodies {
        // Masses closer than 2·radius_m touch: grid neighbours that close would push each other
        // apart at rest, a stiffness the springs never asked for.
        let diameter = 2.0 * sc.radius_m;
        let multi = |b: &&Body| b.mass_count_bound() > 1;
        if let Some((i, b)) = scene
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| multi(b))
            .find(|(_, b)| diameter >= b.finest_spacing_m())
        {
            let smallest = scene
                .bodies
                .iter()
                .filter(multi)
                .map(Body::finest_spacing_m)
                .fold(f32::INFINITY, f32::min);
            // Three significant digits, rounded down.
            let suggest = 0.45 * f64::from(smallest);
            let decimals = (2 - suggest.log10().floor() as i32).max(0) as usize;
            let scale = 10f64.powi(decimals as i32);
            let suggest = format!("{:.*}", decimals, (suggest * scale).floor() / scale);
            return fail(
                format!("{f}.radius_m"),
                format!(
                    "2 · radius_m = {diameter} m must be less than the spacing of every body whose masses collide with each other, \
                     but bodies[{i}] ('{}') has {} = {} m, so its {} neighbours would repel at rest; \
                     use radius_m = {suggest} m (0.45 · the smallest spacing) or less, or set within_bodies = false",
                    b.name,
                    if cloth(b) {
                        "a shortest edge"
                    } else {
                        "spacing_m"
                    },
                    b.finest_spacing_m(),
                    if cloth(b) { "mesh" } else { "grid" },
                ),
            );
        }
    }
    if let Err(why) = scene.solver.integrator.supports(&scene.effects) {
        let field = why.scene_field();
        return fail(
            "solver.integrator",
            format!(
                "{why} ({field}): use {}, or remove [{field}]",
                why.instead("\"")
            ),
        );
    }
    Ok(())
}
