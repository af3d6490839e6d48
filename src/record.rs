//! The recorder: turns snapshots into Rerun entities on the `frame` and `sim_time` timelines.
//!
//! Layout (see ARCHITECTURE.md): `world/<body>/masses` points, `world/<body>/springs` lines
//! coloured by strain, `world/colliders/*`, `world/ground`; `energy/*` and `stats/*` scalars;
//! `scene`, `legend` text documents. What never changes is logged once with `log_static`.

use glam::Vec3;
use rerun::RecordingStream;

use crate::model::{Model, Shape};
use crate::settings::Settings;
use crate::state::Snapshot;

type RResult<T = ()> = Result<T, rerun::RecordingStreamError>;

/// Colour of a strain value on the diverging scale: blue (compressed by `range` or more), light
/// grey (at rest), red (stretched by `range` or more).
pub fn strain_color(strain: f32, range: f32) -> [u8; 3] {
    const BLUE: [f32; 3] = [59.0, 76.0, 192.0];
    const GREY: [f32; 3] = [221.0, 221.0, 221.0];
    const RED: [f32; 3] = [180.0, 4.0, 38.0];
    let t = if strain.is_finite() {
        (strain / range).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let (end, w) = if t < 0.0 { (BLUE, -t) } else { (RED, t) };
    let mix = |i: usize| (GREY[i] + (end[i] - GREY[i]) * w).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// The default layout: the 3D view beside the energy and statistics plots.
pub fn blueprint() -> rerun::blueprint::Blueprint {
    use rerun::blueprint::components::PanelState;
    use rerun::blueprint::{
        Blueprint, Horizontal, Spatial3DView, TextDocumentView, TimeSeriesView, Vertical,
    };
    Blueprint::new(
        Horizontal::new([
            Spatial3DView::new("world").with_origin("/world").into(),
            Vertical::new([
                TimeSeriesView::new("energy (J)")
                    .with_origin("/energy")
                    .into(),
                TimeSeriesView::new("step statistics")
                    .with_origin("/stats")
                    .into(),
                TextDocumentView::new("strain colour scale")
                    .with_origin("/legend")
                    .into(),
            ])
            .with_row_shares([0.45, 0.35, 0.2])
            .into(),
        ])
        .with_column_shares([0.62, 0.38]),
    )
    .with_auto_views(false)
    .with_selection_panel(rerun::blueprint::SelectionPanel::from_state(
        PanelState::Collapsed,
    ))
    .with_blueprint_panel(rerun::blueprint::BlueprintPanel::from_state(
        PanelState::Collapsed,
    ))
}

/// Entity paths for the energy series, with their display names.
const ENERGY_SERIES: [(&str, &str); 11] = [
    ("energy/kinetic", "kinetic"),
    ("energy/elastic", "elastic (springs)"),
    ("energy/gravity", "gravitational"),
    ("energy/contact", "contact (penalty)"),
    ("energy/dissipated", "dissipated (all of the below)"),
    ("energy/dissipated_damping", "dissipated by spring damping"),
    ("energy/dissipated_drag", "dissipated by air drag"),
    (
        "energy/dissipated_contact",
        "dissipated by contact damping and friction",
    ),
    ("energy/collider_work", "work done by moving colliders"),
    ("energy/total", "total mechanical"),
    ("energy/balance", "total + dissipated − collider work"),
];

pub struct Recorder {
    rec: RecordingStream,
    model: std::sync::Arc<Model>,
    strain_range: f32,
    /// Per body: springs as (a, b) pairs reused to build line strips each frame.
    strips: Vec<Vec<[Vec3; 2]>>,
    colors: Vec<Vec<rerun::Color>>,
    /// The implicit integrator's solver statistics are logged too.
    implicit: bool,
    /// `world/colliders/<kind>_<k>`, k counting colliders of one kind.
    collider_paths: Vec<String>,
}

/// Lowest and highest corner of a set of points.
fn extent(x: &[Vec3]) -> (Vec3, Vec3) {
    x.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

/// Logged only when the scene's springs yield or tear.
const PLASTIC_SERIES: (&str, &str) = (
    "energy/dissipated_plastic",
    "let go by plastic flow and tearing",
);
const BROKEN_SERIES: (&str, &str) = ("stats/broken_springs", "broken springs (tearing)");

impl Recorder {
    pub fn new(rec: RecordingStream, model: std::sync::Arc<Model>, strain_range: f32) -> Self {
        let strips = model
            .bodies
            .iter()
            .map(|b| Vec::with_capacity(b.springs.len()))
            .collect();
        let colors = model
            .bodies
            .iter()
            .map(|b| Vec::with_capacity(b.springs.len()))
            .collect();
        let mut counts = std::collections::HashMap::new();
        let collider_paths = model
            .effects
            .colliders
            .iter()
            .map(|c| {
                let k = counts.entry(c.kind()).or_insert(0);
                *k += 1;
                format!("world/colliders/{}_{}", c.kind(), *k - 1)
            })
            .collect();
        Self {
            rec,
            model,
            strain_range,
            strips,
            colors,
            implicit: false,
            collider_paths,
        }
    }

    /// Everything that does not change over the run.
    pub fn log_static(
        &mut self,
        scene_name: &str,
        scene_text: &str,
        settings: &Settings,
        backend: &str,
    ) -> RResult {
        self.implicit = settings.integrator == crate::integrator::Integrator::Implicit;
        let rec = &self.rec;
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Y_UP())?;
        rec.log_static(
            "scene",
            &rerun::TextDocument::from_markdown(format!(
                "# {scene_name}\n\nintegrator `{}`, dt = {:.3e} s, {} substeps per frame, {} frames at {} Hz, backend {backend}\n\n```toml\n{scene_text}\n```",
                settings.integrator, settings.dt_secs, settings.substeps, settings.frames, settings.frame_rate_hz
            )),
        )?;
        let r = self.strain_range;
        rec.log_static(
            "legend",
            &rerun::TextDocument::from_markdown(format!(
                "Springs are coloured by strain (|x| − L) / L on a fixed scale:\n\n\
                 | colour | strain |\n|---|---|\n\
                 | blue | −{r} or less (compressed) |\n| light grey | 0 (at rest) |\n| red | +{r} or more (stretched) |\n\n\
                 Set the range with `[view] strain_range` in the scene file. Pinned masses are black; \
                 `stats/max_strain` plots the largest |strain| of each frame. A spring that tore is \
                 no longer drawn, and `stats/broken_springs` counts them over time."
            )),
        )?;
        for (path, name) in ENERGY_SERIES {
            rec.log_static(path, &rerun::SeriesLines::new().with_names([name]))?;
        }
        let fx = &self.model.effects;
        for ((path, name), on) in [
            (PLASTIC_SERIES, fx.springs_change()),
            (BROKEN_SERIES, fx.tearing),
        ] {
            if on {
                rec.log_static(path, &rerun::SeriesLines::new().with_names([name]))?;
            }
        }
        for (path, name) in [
            ("stats/max_strain", "max |strain|"),
            ("stats/step_ms", "wall time per frame (ms)"),
            ("stats/substeps", "substeps per frame"),
            ("stats/projections", "contact safeguard projections"),
            (
                "stats/cg_iterations",
                "conjugate-gradient iterations (implicit, most in a step)",
            ),
            (
                "stats/cg_residual",
                "conjugate-gradient relative residual (implicit, largest)",
            ),
        ] {
            rec.log_static(path, &rerun::SeriesLines::new().with_names([name]))?;
        }
        let m = &self.model;
        for b in &m.bodies {
            let range = b.masses.start as usize..b.masses.end as usize;
            let spacing = b
                .springs
                .clone()
                .map(|s| m.springs[s as usize].rest_m)
                .fold(f32::INFINITY, f32::min);
            let radius = if spacing.is_finite() {
                0.12 * spacing
            } else {
                0.02
            };
            let colors: Vec<rerun::Color> = m.inv_mass[range]
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
                format!("world/{}/masses", b.name),
                &rerun::Points3D::update_fields()
                    .with_colors(colors)
                    .with_radii([radius]),
            )?;
            rec.log_static(
                format!("world/{}/springs", b.name),
                &rerun::LineStrips3D::update_fields().with_radii([0.25 * radius]),
            )?;
        }
        if let Some(g) = &m.effects.ground {
            // A grid of lines at the ground height, half a metre beyond the bodies' starting extent,
            // so that the viewer frames the scene rather than the floor.
            let (lo, hi) = extent(&m.initial.x);
            let step = 0.25f32;
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
                "world/ground",
                &rerun::LineStrips3D::new(lines)
                    .with_colors([rerun::Color::from_rgb(120, 120, 120)])
                    .with_radii([0.002]),
            )?;
        }
        let blue = rerun::Color::from_rgb(90, 140, 200);
        for (c, path) in m.effects.colliders.iter().zip(&self.collider_paths) {
            // The shape once; a moving collider's position on the timelines (log_snapshot).
            let start = c.path.pose_at(0.0).position_m;
            match c.shape {
                Shape::Sphere { radius_m } => rec.log_static(
                    path.as_str(),
                    &rerun::Ellipsoids3D::from_centers_and_radii([start], [radius_m])
                        .with_colors([blue])
                        .with_fill_mode(rerun::FillMode::Solid),
                )?,
                Shape::Box { half_extents_m } => rec.log_static(
                    path.as_str(),
                    &rerun::Boxes3D::from_centers_and_half_sizes([start], [half_extents_m])
                        .with_colors([blue])
                        .with_fill_mode(rerun::FillMode::Solid),
                )?,
                Shape::Plane { normal } => {
                    // A square of lines about the plane's point, as wide as the scene's extent.
                    let (lo, hi) = extent(&m.initial.x);
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
                        path.as_str(),
                        &rerun::LineStrips3D::new(lines)
                            .with_colors([blue])
                            .with_radii([0.003]),
                    )?
                }
            }
        }
        Ok(())
    }

    /// One frame on both timelines.
    pub fn log_snapshot(&mut self, snap: &Snapshot) -> RResult {
        let rec = &self.rec;
        rec.set_time_sequence("frame", snap.frame as i64);
        rec.set_duration_secs("sim_time", snap.time_secs);
        let m = &self.model;
        for (bi, b) in m.bodies.iter().enumerate() {
            let pos = &snap.positions[b.masses.start as usize..b.masses.end as usize];
            rec.log(
                format!("world/{}/masses", b.name),
                &rerun::Points3D::update_fields().with_positions(pos.iter().copied()),
            )?;
            if b.springs.is_empty() {
                continue;
            }
            let (strips, colors) = (&mut self.strips[bi], &mut self.colors[bi]);
            strips.clear();
            colors.clear();
            for si in b.springs.clone() {
                let strain = snap.strain[si as usize];
                // A broken spring has no strain (NaN) and is not drawn, so the tear shows.
                if strain.is_nan() {
                    continue;
                }
                let s = &m.springs[si as usize];
                strips.push([snap.positions[s.a as usize], snap.positions[s.b as usize]]);
                let [r, g, bl] = strain_color(strain, self.strain_range);
                colors.push(rerun::Color::from_rgb(r, g, bl));
            }
            rec.log(
                format!("world/{}/springs", b.name),
                &rerun::LineStrips3D::update_fields()
                    .with_strips(strips.iter().map(|s| s.to_vec()))
                    .with_colors(colors.iter().copied()),
            )?;
        }
        for ((c, p), path) in m
            .effects
            .colliders
            .iter()
            .zip(&snap.collider_positions)
            .zip(&self.collider_paths)
        {
            if c.path.is_fixed() {
                continue;
            }
            match c.shape {
                Shape::Sphere { .. } => rec.log(
                    path.as_str(),
                    &rerun::Ellipsoids3D::update_fields().with_centers([*p]),
                )?,
                Shape::Box { .. } => rec.log(
                    path.as_str(),
                    &rerun::Boxes3D::update_fields().with_centers([*p]),
                )?,
                Shape::Plane { .. } => {}
            }
        }
        let e = &snap.energies;
        let values = [
            e.kinetic_j,
            e.elastic_j,
            e.gravity_j,
            e.contact_j,
            e.ledger.dissipated_j(),
            e.ledger.damping_j,
            e.ledger.drag_j,
            e.ledger.contact_j,
            e.ledger.collider_work_j,
            e.total_j(),
            e.balance_j(),
        ];
        for ((path, _), v) in ENERGY_SERIES.iter().zip(values) {
            rec.log(*path, &rerun::Scalars::single(v))?;
        }
        if m.effects.springs_change() {
            rec.log(
                PLASTIC_SERIES.0,
                &rerun::Scalars::single(e.ledger.plastic_j),
            )?;
        }
        if m.effects.tearing {
            rec.log(
                BROKEN_SERIES.0,
                &rerun::Scalars::single(snap.broken_springs() as f64),
            )?;
        }
        let st = &snap.stats;
        rec.log(
            "stats/max_strain",
            &rerun::Scalars::single(f64::from(snap.max_abs_strain())),
        )?;
        rec.log("stats/step_ms", &rerun::Scalars::single(st.step_ms))?;
        rec.log(
            "stats/substeps",
            &rerun::Scalars::single(f64::from(st.substeps)),
        )?;
        rec.log(
            "stats/projections",
            &rerun::Scalars::single(f64::from(st.projections)),
        )?;
        if self.implicit {
            let iterations = f64::from(st.solver_iterations);
            rec.log("stats/cg_iterations", &rerun::Scalars::single(iterations))?;
            rec.log(
                "stats/cg_residual",
                &rerun::Scalars::single(st.solver_residual),
            )?;
        }
        Ok(())
    }
}
