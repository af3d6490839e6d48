//! What is logged once, static: the view's coordinates, the scene and legend documents, each
//! series' name and colour, each body's topology (mass colours, pins, triangles, spring kinds),
//! the ground and the colliders' shapes.

use glam::Vec3;
use rerun::RecordingStream;

use super::error::RResult;
use super::framing::{Framing, extent};
use super::histogram;
use super::palette::{COLLIDER, YELLOW, color};
use super::recorder::{BodyRec, Recorder, Root};
use super::series::all_series;
use crate::model::{Collider, GroundCollider, Model, Shape};
use crate::scene::settings::Settings;

impl Recorder {
    /// Everything that does not change over the run.
    pub fn log_static(
        &mut self,
        scene_name: &str,
        scene_text: &str,
        settings: &Settings,
        backend: &str,
    ) -> RResult {
        self.implicit = settings.integrator.newton();
        // Newton's and VBD's solves report a residual against a rule.
        self.solver = settings.integrator.scheme().assembles_blocks();
        let rec = &self.rec;
        let root = &self.root;
        if root.is_whole() {
            self.log_documents(scene_name, scene_text, settings, backend)?;
            super::blueprint::send_blueprint(
                rec,
                Framing::at_start(&self.model),
                super::blueprint::Takes::Now,
            )?;
        }
        for series in all_series() {
            if self.has(series.when) {
                rec.log_static(
                    root.series(series.path),
                    &rerun::SeriesLines::new()
                        .with_names([series.name])
                        .with_colors([rerun::Color::from(series.color.rgb)]),
                )?;
            }
        }
        let r = self.strain_range;
        rec.log_static(
            root.series("stats/strain_histogram"),
            &rerun::BarChart::update_fields()
                .with_abscissa(histogram::centres(r))
                .with_widths(histogram::widths(r))
                .with_color(rerun::Color::from_rgb(120, 130, 150)),
        )?;
        rec.log_static(
            root.world("most_strained"),
            &rerun::LineStrips3D::update_fields().with_colors([color(YELLOW.rgb)]),
        )?;
        rec.log_static(
            root.world("most_strained/label"),
            &rerun::Points3D::update_fields()
                .with_colors([color(YELLOW.rgb)])
                .with_radii([rerun::Radius::new_ui_points(2.0)])
                .with_show_labels(true),
        )?;
        for b in &self.bodies {
            log_body_static(rec, root, &self.model, b)?;
        }
        let m = &self.model;
        if let Some(g) = &m.effects.ground {
            log_ground(rec, &root.world("ground"), g, &m.initial.x)?;
        }
        for (c, path) in m.effects.colliders.iter().zip(&self.collider_paths) {
            log_collider_shape(rec, c, path, &m.initial.x)?;
        }
        Ok(())
    }

    /// The view's axes and the scene and legend documents: a whole recording's, once.
    fn log_documents(
        &self,
        scene_name: &str,
        scene_text: &str,
        settings: &Settings,
        backend: &str,
    ) -> RResult {
        let rec = &self.rec;
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Y_UP())?;
        rec.log_static(
            "scene",
            &rerun::TextDocument::from_markdown(format!(
                "# {scene_name}\n\nintegrator `{}`, dt = {:.3e} s, {} substeps per frame, {} frames at {} Hz, backend {backend}\n\n```toml\n{scene_text}\n```",
                settings.integrator, settings.dt_secs, settings.substeps, settings.frames, settings.frame_rate_hz
            )),
        )?;
        rec.log_static("legend", &rerun::TextDocument::from_markdown(self.legend()))?;
        Ok(())
    }
}

/// A body's masses (pins black), pins, triangles and the static values of its spring lines.
fn log_body_static(rec: &RecordingStream, root: &Root, m: &Model, b: &BodyRec) -> RResult {
    let radius = point_radius(m, b);
    let inv_mass = &m.inv_mass[b.masses.clone()];
    if b.masses_per_frame {
        let colors: Vec<rerun::Color> = inv_mass
            .iter()
            .map(|&w| {
                if w == 0.0 {
                    rerun::Color::from_rgb(0, 0, 0)
                } else {
                    rerun::Color::from_rgb(230, 170, 40)
                }
            })
            .collect();
        rec.log_static(
            root.world(&format!("{}/masses", b.name)),
            &rerun::Points3D::update_fields()
                .with_colors(colors)
                .with_radii([radius]),
        )?;
    }
    if b.surface.is_some() {
        // Pins never move: shown once, whatever else is logged.
        let pins: Vec<Vec3> = inv_mass
            .iter()
            .zip(&m.initial.x[b.masses.clone()])
            .filter(|(w, _)| **w == 0.0)
            .map(|(_, x)| *x)
            .collect();
        if !pins.is_empty() {
            rec.log_static(
                root.world(&format!("{}/pins", b.name)),
                &rerun::Points3D::new(pins)
                    .with_colors([rerun::Color::from_rgb(0, 0, 0)])
                    .with_radii([2.0 * radius]),
            )?;
        }
    }
    if let Some(s) = &b.surface
        && !s.surface.can_tear
    {
        rec.log_static(
            s.path.as_str(),
            &rerun::Mesh3D::update_fields()
                .with_triangle_indices(s.surface.triangles.iter().copied()),
        )?;
    }
    if let Some(lines) = &b.lines {
        // Thinner over a surface, where they draw its edges.
        let width = if b.surface.is_some() { 0.15 } else { 0.25 };
        rec.log_serialized_batches(
            lines.path.as_str(),
            true,
            lines.static_batches(m, width * radius),
        )?;
    }
    Ok(())
}

/// The radius a body's masses are drawn with: an eighth of its shortest spring.
pub(super) fn point_radius(m: &Model, b: &BodyRec) -> f32 {
    let spacing = b
        .springs
        .clone()
        .map(|s| m.springs[s].rest_m)
        .fold(f32::INFINITY, f32::min);
    if spacing.is_finite() {
        0.12 * spacing
    } else {
        0.02
    }
}

/// The most ground lines drawn each way, whatever the scene's extent.
const MOST_GROUND_LINES: f32 = 64.0;

/// The ground grid's spacing across `width` metres: 0.25 m, or where that would draw more than
/// `MOST_GROUND_LINES` lines, the next of 1, 2 or 5 × 10ⁿ m that draws no more (a body 1e30 m
/// wide once asked for 4e30 lines, and the allocation aborted the run).
fn ground_spacing(width: f32) -> f32 {
    let least = width / MOST_GROUND_LINES;
    if least <= 0.25 {
        return 0.25;
    }
    let decade = 10f32.powf(least.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|s| *s >= least)
        .unwrap_or(10.0 * decade)
}

/// A grid of lines at the ground height, half a metre beyond the bodies' starting extent `x`, so
/// that the viewer frames the scene rather than the floor; none where that extent is not finite.
fn log_ground(rec: &RecordingStream, path: &str, g: &GroundCollider, x: &[Vec3]) -> RResult {
    let (lo, hi) = extent(x);
    let width = (hi.x - lo.x).max(hi.z - lo.z) + 1.0;
    if !width.is_finite() {
        return Ok(());
    }
    let step = ground_spacing(width);
    let x0 = ((lo.x - 0.5) / step).floor() as i32;
    let x1 = ((hi.x + 0.5) / step).ceil() as i32;
    let z0 = ((lo.z - 0.5) / step).floor() as i32;
    let z1 = ((hi.z + 0.5) / step).ceil() as i32;
    let h = g.height_m;
    let (xa, xb, za, zb) = (
        x0 as f32 * step,
        x1 as f32 * step,
        z0 as f32 * step,
        z1 as f32 * step,
    );
    let lines: Vec<[Vec3; 2]> = (x0..=x1)
        .map(|i| {
            [
                Vec3::new(i as f32 * step, h, za),
                Vec3::new(i as f32 * step, h, zb),
            ]
        })
        .chain((z0..=z1).map(|k| {
            [
                Vec3::new(xa, h, k as f32 * step),
                Vec3::new(xb, h, k as f32 * step),
            ]
        }))
        .collect();
    rec.log_static(
        path,
        &rerun::LineStrips3D::new(lines)
            .with_colors([rerun::Color::from_rgb(120, 120, 120)])
            .with_radii([0.002]),
    )?;
    Ok(())
}

/// A collider's shape, once, where it starts; a moving collider's position goes on the timelines
/// (`log_snapshot`). A plane is drawn as a square of lines about its point, as wide as the
/// scene's starting extent `x`.
fn log_collider_shape(rec: &RecordingStream, c: &Collider, path: &str, x: &[Vec3]) -> RResult {
    let sand = color(COLLIDER.rgb);
    let start = c.path.pose_at(0.0).position_m;
    match c.shape {
        Shape::Sphere { radius_m } => rec.log_static(
            path,
            &rerun::Ellipsoids3D::from_centers_and_radii([start], [radius_m])
                .with_colors([sand])
                .with_fill_mode(rerun::FillMode::Solid),
        )?,
        Shape::Box { half_extents_m } => rec.log_static(
            path,
            &rerun::Boxes3D::from_centers_and_half_sizes([start], [half_extents_m])
                .with_colors([sand])
                .with_fill_mode(rerun::FillMode::Solid),
        )?,
        Shape::Plane { normal } => {
            let (lo, hi) = extent(x);
            let half = (0.5 * (hi - lo).length() + 0.5).min(10.0);
            let u = normal.any_orthonormal_vector();
            let w = normal.cross(u);
            let lines: Vec<[Vec3; 2]> = (-4..=4)
                .flat_map(|k| {
                    let s = half * k as f32 / 4.0;
                    [
                        [start + s * u - half * w, start + s * u + half * w],
                        [start + s * w - half * u, start + s * w + half * u],
                    ]
                })
                .collect();
            rec.log_static(
                path,
                &rerun::LineStrips3D::new(lines)
                    .with_colors([sand])
                    .with_radii([0.003]),
            )?
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ground_grid_draws_a_bounded_number_of_lines_at_any_extent() {
        assert_eq!(ground_spacing(2.0), 0.25);
        assert_eq!(ground_spacing(16.0), 0.25);
        assert_eq!(ground_spacing(17.0), 0.5);
        assert_eq!(ground_spacing(100.0), 2.0);
        for width in [1.0f32, 33.0, 1e3, 7.7e6, 1e30, 3e38] {
            let step = ground_spacing(width);
            assert!(width / step <= MOST_GROUND_LINES, "{width}: {step}");
            assert!(step >= 0.25 && step.is_finite(), "{width}: {step}");
        }
    }
}
