//! The recorder: turns snapshots into Rerun entities on the `frame` and `sim_time` timelines.
//!
//! Layout (see ARCHITECTURE.md and the README, "What a recording holds"):
//! - `world/<body>/surface`: a sheet, or a block's outer faces, as a `Mesh3D` coloured by strain
//!   ([`surface`]); triangle indices logged once, per frame only vertex positions and colours;
//! - `world/<body>/springs`: line segments coloured by strain with hover values ([`springs`]),
//!   for small bodies and strands by default (`--springs`);
//! - `world/<body>/masses`: points for strands, and for sheets and blocks with `--masses`;
//!   `world/<body>/pins` for the pinned masses of sheets and blocks, once;
//! - `world/most_strained`: the most strained spring of the frame, labelled;
//! - `world/colliders/*`, `world/ground`; `energy/*` in joules; `stats/*`, one plot per unit, and
//!   `stats/strain_histogram` ([`histogram`]); `scene`, `legend` text documents.
//!
//! What never changes is logged once with `log_static`; nothing is allocated per spring per frame.

pub mod histogram;
pub mod springs;
pub mod surface;

use std::time::Instant;

use glam::Vec3;
use rerun::RecordingStream;

use crate::model::{Model, Shape};
use crate::settings::Settings;
use crate::state::Snapshot;

pub use springs::SpringSelection;

/// Why a frame could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error(transparent)]
    Rerun(#[from] rerun::RecordingStreamError),
    /// Rerun's component layout is not what this build expects (a version mismatch).
    #[error("internal: {0}")]
    Layout(String),
}

type RResult<T = ()> = Result<T, RecordError>;

/// What a recording holds beyond its defaults (`hooke run --springs … --masses`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecordOptions {
    /// Which springs are logged as lines; `None`: each body's default for its size
    /// ([`springs::DEFAULT_MAX_SPRINGS`]).
    pub springs: Option<SpringSelection>,
    /// Log the masses of sheets and blocks as points every frame (their surface's vertices are
    /// the same positions; strands always log theirs).
    pub masses: bool,
}

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

/// The default layout: the 3D view beside one plot per unit, the strain histogram and the
/// colour legend. Returns the layout and the blueprint paths of its plots (the histogram's
/// included).
fn layout() -> (rerun::blueprint::Blueprint, Vec<rerun::EntityPath>) {
    use rerun::blueprint::components::PanelState;
    use rerun::blueprint::{
        BarChartView, Blueprint, ContainerLike, Horizontal, Spatial3DView, Tabs, TextDocumentView,
        TimeSeriesView, Vertical,
    };
    let mut plots = Vec::new();
    let mut plot = |name: &str, p: Plot| {
        let view: ContainerLike = TimeSeriesView::new(name)
            .with_origin("/")
            .with_contents(
                SERIES
                    .iter()
                    .chain(&MORE_SERIES)
                    .filter(|s| s.plot == p)
                    .map(|s| format!("+ /{}", s.path)),
            )
            .into();
        if let ContainerLike::View(v) = &view {
            plots.push(v.blueprint_path());
        }
        view
    };
    let energy = plot("energy (J)", Plot::Energy);
    let strain = plot("strain", Plot::Strain);
    let millis = plot("time per frame (ms)", Plot::Millis);
    let counts = plot("counts per frame", Plot::Count);
    let histogram: ContainerLike = BarChartView::new("strain histogram")
        .with_origin("/stats/strain_histogram")
        .into();
    if let ContainerLike::View(v) = &histogram {
        plots.push(v.blueprint_path());
    }
    let blueprint = Blueprint::new(
        Horizontal::new([
            Spatial3DView::new("world").with_origin("/world").into(),
            Vertical::new([
                energy,
                Horizontal::new([strain, histogram]).into(),
                Horizontal::new([millis, counts]).into(),
                Tabs::new([
                    TextDocumentView::new("legend")
                        .with_origin("/legend")
                        .into(),
                    TextDocumentView::new("scene").with_origin("/scene").into(),
                ])
                .into(),
            ])
            .with_row_shares([0.34, 0.22, 0.22, 0.22])
            .into(),
        ])
        .with_column_shares([0.6, 0.4]),
    )
    .with_auto_views(false)
    .with_selection_panel(rerun::blueprint::SelectionPanel::from_state(
        PanelState::Collapsed,
    ))
    .with_blueprint_panel(rerun::blueprint::BlueprintPanel::from_state(
        PanelState::Collapsed,
    ));
    (blueprint, plots)
}

/// Sends the default layout to `rec`, made active at once.
///
/// Its plots have no legend inside them: a legend is drawn over the plot, and in plots this
/// size it hides the data. Each series has a fixed colour instead, named in the `legend`
/// document, and the viewer names a line when it is hovered. Rerun 0.36's Rust blueprint API
/// cannot set a view's legend, so the legend properties are logged into the blueprint's own
/// store beside the layout, as the viewer reads them.
pub fn send_blueprint(rec: &RecordingStream) -> RResult {
    use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreKind};
    use rerun::external::re_sdk_types::blueprint::archetypes::PlotLegend;
    let (blueprint, plots) = layout();
    let activation = rerun::blueprint::BlueprintActivation {
        make_active: true,
        make_default: true,
    };
    // The layout's messages, as the SDK makes them, caught in memory.
    let (mem, layout_msgs) = rerun::RecordingStreamBuilder::new(APPLICATION_ID).memory()?;
    blueprint.send(&mem, activation)?;
    let mut msgs: Vec<LogMsg> = layout_msgs
        .take()
        .into_iter()
        .filter(|m| {
            m.store_id().kind() == StoreKind::Blueprint
                && !matches!(m, LogMsg::BlueprintActivationCommand(_))
        })
        .collect();
    let Some(blueprint_id) = msgs.first().map(|m| m.store_id().clone()) else {
        return Ok(());
    };
    // The legends, logged into that same blueprint store.
    let (legends, legend_msgs) = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(blueprint_id.recording_id().clone())
        .blueprint()
        .memory()?;
    legends.set_time_sequence("blueprint", 0);
    for view in &plots {
        legends.log(
            format!("{view}/PlotLegend"),
            &PlotLegend::new().with_visible(false),
        )?;
    }
    msgs.extend(
        legend_msgs
            .take()
            .into_iter()
            .filter(|m| matches!(m, LogMsg::ArrowMsg(..))),
    );
    rec.send_blueprint(
        msgs,
        BlueprintActivationCommand {
            blueprint_id,
            make_active: activation.make_active,
            make_default: activation.make_default,
        },
    );
    Ok(())
}

/// The application every recording of ours belongs to: the viewer keeps one layout per id.
pub const APPLICATION_ID: &str = "hooke";

/// Which plot of the default layout a series is drawn in: one per unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plot {
    /// Joules.
    Energy,
    /// Dimensionless strain (ratios).
    Strain,
    /// Wall milliseconds per frame.
    Millis,
    /// Counts per frame.
    Count,
    /// In the recording, in no plot of the default layout (a relative residual: the user adds
    /// a plot, with a log scale, when they want it).
    Unplotted,
}

/// One scalar series: its entity path, its name (shown when its line is hovered), its plot,
/// its colour and that colour's name for the legend, and when the recording has it.
pub struct Series {
    pub path: &'static str,
    pub name: &'static str,
    pub plot: Plot,
    pub color: Rgb,
    pub when: When,
}

/// A series colour and its name in the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rgb {
    pub rgb: [u8; 3],
    pub name: &'static str,
}

const fn rgb(r: u8, g: u8, b: u8, name: &'static str) -> Rgb {
    Rgb {
        rgb: [r, g, b],
        name,
    }
}

// Series colours: distinct within each plot on the viewer's dark background.
const ORANGE: Rgb = rgb(255, 160, 40, "orange");
const GREEN: Rgb = rgb(90, 200, 90, "green");
const BLUE: Rgb = rgb(80, 140, 255, "blue");
const VIOLET: Rgb = rgb(170, 110, 230, "violet");
const RED: Rgb = rgb(230, 60, 60, "red");
const SALMON: Rgb = rgb(245, 150, 130, "salmon");
const PINK: Rgb = rgb(240, 110, 200, "pink");
const BROWN: Rgb = rgb(170, 120, 70, "brown");
const DARK_RED: Rgb = rgb(140, 30, 40, "dark red");
const CYAN: Rgb = rgb(60, 200, 220, "cyan");
const WHITE: Rgb = rgb(235, 235, 235, "white");
// The yellow of `world/most_strained`, so that the strain plot and the marked spring match.
const YELLOW: Rgb = rgb(255, 200, 0, "yellow");
const GREY: Rgb = rgb(150, 150, 150, "grey");

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum When {
    Always,
    /// Springs yield or tear.
    SpringsChange,
    Tearing,
    Implicit,
}

/// Every scalar series, in the order they are logged each frame.
#[rustfmt::skip]
pub const SERIES: [Series; 17] = [
    s("energy/kinetic", "kinetic", Plot::Energy, ORANGE, When::Always),
    s("energy/elastic", "elastic", Plot::Energy, GREEN, When::Always),
    s("energy/gravity", "gravity", Plot::Energy, BLUE, When::Always),
    s("energy/contact", "contact", Plot::Energy, VIOLET, When::Always),
    s("energy/dissipated", "dissipated", Plot::Energy, RED, When::Always),
    s("energy/dissipated_damping", "· damping", Plot::Energy, SALMON, When::Always),
    s("energy/dissipated_drag", "· drag", Plot::Energy, PINK, When::Always),
    s("energy/dissipated_contact", "· friction", Plot::Energy, BROWN, When::Always),
    s("energy/dissipated_plastic", "· plastic", Plot::Energy, DARK_RED, When::SpringsChange),
    s("energy/collider_work", "collider work", Plot::Energy, CYAN, When::Always),
    s("energy/total", "total", Plot::Energy, WHITE, When::Always),
    s("energy/balance", "balance", Plot::Energy, YELLOW, When::Always),
    s("stats/max_strain", "max |strain|", Plot::Strain, YELLOW, When::Always),
    s("stats/step_ms", "stepping", Plot::Millis, BLUE, When::Always),
    s("stats/record_ms", "recording", Plot::Millis, ORANGE, When::Always),
    s("stats/substeps", "substeps", Plot::Count, WHITE, When::Always),
    s("stats/projections", "projections", Plot::Count, GREEN, When::Always),
];

/// Series beyond [`SERIES`] that only some runs have.
#[rustfmt::skip]
pub const MORE_SERIES: [Series; 3] = [
    s("stats/broken_springs", "broken springs", Plot::Count, RED, When::Tearing),
    s("stats/cg_iterations", "CG iterations", Plot::Count, CYAN, When::Implicit),
    s("stats/cg_residual", "CG residual", Plot::Unplotted, GREY, When::Implicit),
];

const fn s(path: &'static str, name: &'static str, plot: Plot, color: Rgb, when: When) -> Series {
    Series {
        path,
        name,
        plot,
        color,
        when,
    }
}

/// One body as it is recorded.
struct BodyRec {
    name: String,
    masses: std::ops::Range<usize>,
    springs: std::ops::Range<usize>,
    surface: Option<SurfaceRec>,
    lines: Option<springs::SpringLines>,
    /// Log the masses as points every frame.
    masses_per_frame: bool,
}

/// A body's surface and the buffers a frame is built in.
struct SurfaceRec {
    path: String,
    surface: surface::Surface,
    /// The vertices are the body's masses in order: positions are a slice of the snapshot's.
    whole_body: bool,
    /// The triangles drawn now, and the broken springs of the body when they were chosen.
    triangles: Vec<[u32; 3]>,
    broken: Option<usize>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    strain: Vec<f32>,
    colors: Vec<rerun::Color>,
}

pub struct Recorder {
    rec: RecordingStream,
    model: std::sync::Arc<Model>,
    strain_range: f32,
    bodies: Vec<BodyRec>,
    /// The implicit integrator's solver statistics are logged too.
    implicit: bool,
    /// `world/colliders/<kind>_<k>`, k counting colliders of one kind.
    collider_paths: Vec<String>,
    histogram: Vec<u64>,
    /// `--springs` was not given: each body logs its default.
    default_springs: bool,
}

/// Lowest and highest corner of a set of points.
fn extent(x: &[Vec3]) -> (Vec3, Vec3) {
    x.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

fn color([r, g, b]: [u8; 3]) -> rerun::Color {
    rerun::Color::from_rgb(r, g, b)
}

/// What each body logs under `opts`, for the start of a run: one line per body.
pub fn describe(model: &Model, opts: &RecordOptions) -> Vec<String> {
    model
        .bodies
        .iter()
        .map(|b| {
            let surface = surface::Surface::of_body(model, b);
            let lines = springs::selected(model, b, opts.springs, surface.is_some()).len();
            let what = match &surface {
                Some(s) => format!("surface of {} triangles", s.triangles.len()),
                None => "masses".to_owned(),
            };
            let springs = if lines == 0 && opts.springs.is_none() && !b.springs.is_empty() {
                format!(
                    "springs left out (more than {} structural; --springs structural or all shows them)",
                    springs::DEFAULT_MAX_SPRINGS
                )
            } else {
                format!("{lines} of {} springs as lines", b.springs.len())
            };
            format!("{}: {what}, {springs}", b.name)
        })
        .collect()
}

impl Recorder {
    pub fn new(
        rec: RecordingStream,
        model: std::sync::Arc<Model>,
        strain_range: f32,
        opts: RecordOptions,
    ) -> Self {
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
        let bodies = model
            .bodies
            .iter()
            .map(|b| {
                let surface = surface::Surface::of_body(&model, b).map(|s| SurfaceRec {
                    path: format!("world/{}/surface", b.name),
                    whole_body: s.is_whole_body(b),
                    triangles: Vec::new(),
                    broken: None,
                    positions: Vec::with_capacity(s.vertex_mass.len()),
                    normals: Vec::with_capacity(s.vertex_mass.len()),
                    strain: Vec::with_capacity(s.vertex_mass.len()),
                    colors: Vec::with_capacity(s.vertex_mass.len()),
                    surface: s,
                });
                let selected = springs::selected(&model, b, opts.springs, surface.is_some());
                BodyRec {
                    name: b.name.clone(),
                    masses: b.masses.start as usize..b.masses.end as usize,
                    springs: b.springs.start as usize..b.springs.end as usize,
                    masses_per_frame: surface.is_none() || opts.masses,
                    lines: (!selected.is_empty()).then(|| {
                        springs::SpringLines::new(format!("world/{}/springs", b.name), selected)
                    }),
                    surface,
                }
            })
            .collect();
        Self {
            rec,
            model,
            strain_range,
            bodies,
            implicit: false,
            collider_paths,
            histogram: Vec::new(),
            default_springs: opts.springs.is_none(),
        }
    }

    fn has(&self, when: When) -> bool {
        match when {
            When::Always => true,
            When::SpringsChange => self.model.effects.springs_change(),
            When::Tearing => self.model.effects.tearing,
            When::Implicit => self.implicit,
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
        rec.log_static("legend", &rerun::TextDocument::from_markdown(self.legend()))?;
        for series in SERIES.iter().chain(&MORE_SERIES) {
            if self.has(series.when) {
                rec.log_static(
                    series.path,
                    &rerun::SeriesLines::new()
                        .with_names([series.name])
                        .with_colors([rerun::Color::from(series.color.rgb)]),
                )?;
            }
        }
        let r = self.strain_range;
        rec.log_static(
            "stats/strain_histogram",
            &rerun::BarChart::update_fields()
                .with_abscissa(histogram::centres(r))
                .with_widths(histogram::widths(r))
                .with_color(rerun::Color::from_rgb(120, 130, 150)),
        )?;
        rec.log_static(
            "world/most_strained",
            &rerun::LineStrips3D::update_fields()
                .with_colors([rerun::Color::from_rgb(255, 200, 0)])
                .with_show_labels(true),
        )?;
        let m = &self.model;
        for b in &self.bodies {
            let spacing = b
                .springs
                .clone()
                .map(|s| m.springs[s].rest_m)
                .fold(f32::INFINITY, f32::min);
            let radius = if spacing.is_finite() {
                0.12 * spacing
            } else {
                0.02
            };
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
                    format!("world/{}/masses", b.name),
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
                        format!("world/{}/pins", b.name),
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
        }
        self.log_ground_and_colliders()?;
        Ok(())
    }

    fn legend(&self) -> String {
        let r = self.strain_range;
        let mut bodies = String::new();
        for b in &self.bodies {
            let shown = b.lines.as_ref().map_or(0, |l| l.springs.len());
            let total = b.springs.len();
            let line = match (&b.surface, shown) {
                (Some(_), 0) if total > 0 && self.default_springs => format!(
                    "surface; its {total} springs are not logged (more than {} structural springs: \
                     add `--springs structural` or `--springs all`)",
                    springs::DEFAULT_MAX_SPRINGS
                ),
                (Some(_), _) => format!("surface, and {shown} of its {total} springs as lines"),
                (None, _) => format!("masses, and {shown} of its {total} springs as lines"),
            };
            bodies.push_str(&format!("- `{}`: {line}\n", b.name));
        }
        format!(
            "Surfaces and springs are coloured by strain (|x| − L) / L on a fixed scale: \
             **blue** −{r} or less (compressed), **light grey** 0 (at rest), **red** +{r} or more \
             (stretched); `[view] strain_range` sets it. A surface vertex takes the colour of its \
             most strained spring, lit as the viewer lights a mesh. Hover a spring for its strain, \
             kind and rest length (at the start, for plastic springs). Pins are black; the yellow \
             line marks the most strained spring (`stats/max_strain`). A torn spring is no longer \
             drawn, and its triangles leave the surface.\n\n{bodies}\n{}",
            self.plot_key()
        )
    }

    /// The colour of each line in each plot: the plots have no legend inside them, which
    /// would hide their data.
    fn plot_key(&self) -> String {
        let plots = [
            (Plot::Energy, "energy (J)"),
            (Plot::Strain, "strain"),
            (Plot::Millis, "time per frame (ms)"),
            (Plot::Count, "counts per frame"),
        ];
        let mut key = String::from("Plot lines (hover a line for its name):\n");
        for (plot, title) in plots {
            let lines: Vec<String> = SERIES
                .iter()
                .chain(&MORE_SERIES)
                .filter(|s| s.plot == plot && self.has(s.when))
                .map(|s| format!("{} **{}**", s.name.trim_start_matches("· "), s.color.name))
                .collect();
            key.push_str(&format!("- *{title}*: {}\n", lines.join(", ")));
        }
        key
    }

    fn log_ground_and_colliders(&self) -> RResult {
        let (rec, m) = (&self.rec, &self.model);
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
        let started = Instant::now();
        self.rec.set_time_sequence("frame", snap.frame as i64);
        self.rec.set_duration_secs("sim_time", snap.time_secs);
        let range = self.strain_range;
        let strain_color = |s: f32| color(strain_color(s, range));
        for bi in 0..self.bodies.len() {
            self.log_body(bi, snap)?;
            let (rec, m, b) = (&self.rec, &self.model, &mut self.bodies[bi]);
            if let Some(lines) = &mut b.lines {
                let batches = lines.frame_batches(snap, m, strain_color)?;
                rec.log_serialized_batches(lines.path.as_str(), false, batches)?;
            }
        }
        self.log_colliders(snap)?;
        self.log_scalars(snap)?;
        histogram::counts(&snap.strain, range, &mut self.histogram);
        self.rec.log(
            "stats/strain_histogram",
            &rerun::BarChart::update_fields().with_values(self.histogram.clone()),
        )?;
        self.rec.log(
            "stats/record_ms",
            &rerun::Scalars::single(started.elapsed().as_secs_f64() * 1e3),
        )?;
        Ok(())
    }

    /// A body's masses and surface for one frame.
    fn log_body(&mut self, bi: usize, snap: &Snapshot) -> RResult {
        let (rec, m, b) = (&self.rec, &self.model, &mut self.bodies[bi]);
        let pos = &snap.positions[b.masses.clone()];
        if b.masses_per_frame {
            rec.log(
                format!("world/{}/masses", b.name),
                &rerun::Points3D::update_fields().with_positions(pos.iter().copied()),
            )?;
        }
        let Some(s) = &mut b.surface else {
            return Ok(());
        };
        if s.surface.can_tear {
            // The triangles change only when a spring of this body broke since they were chosen.
            let broken = snap.strain[b.springs.clone()]
                .iter()
                .filter(|x| x.is_nan())
                .count();
            if s.broken != Some(broken) {
                s.triangles = s.surface.intact_triangles(&snap.strain);
                s.broken = Some(broken);
                rec.log(
                    s.path.as_str(),
                    &rerun::Mesh3D::update_fields()
                        .with_triangle_indices(s.triangles.iter().copied()),
                )?;
            }
        } else if s.triangles.is_empty() {
            s.triangles = s.surface.triangles.clone();
        }
        s.positions.clear();
        if s.whole_body {
            s.positions.extend_from_slice(pos);
        } else {
            s.positions.extend(
                s.surface
                    .vertex_mass
                    .iter()
                    .map(|&i| snap.positions[i as usize]),
            );
        }
        surface::vertex_normals(&s.positions, &s.triangles, &mut s.normals);
        surface::vertex_strain(m, &snap.strain, &s.surface.vertex_mass, &mut s.strain);
        let two_sided = s.surface.two_sided;
        let range = self.strain_range;
        s.colors.clear();
        s.colors
            .extend(s.strain.iter().zip(&s.normals).map(|(&strain, &n)| {
                color(surface::shaded(
                    strain_color(strain, range),
                    surface::shade(n, two_sided),
                ))
            }));
        rec.log(
            s.path.as_str(),
            &rerun::Mesh3D::update_fields()
                .with_vertex_positions(s.positions.iter().copied())
                .with_vertex_colors(s.colors.iter().copied()),
        )?;
        Ok(())
    }

    fn log_colliders(&self, snap: &Snapshot) -> RResult {
        let (rec, m) = (&self.rec, &self.model);
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
        Ok(())
    }

    fn log_scalars(&self, snap: &Snapshot) -> RResult {
        let (rec, m) = (&self.rec, &self.model);
        let e = &snap.energies;
        let st = &snap.stats;
        let most = most_strained(&snap.strain);
        let value = |path: &str| -> f64 {
            match path {
                "energy/kinetic" => e.kinetic_j,
                "energy/elastic" => e.elastic_j,
                "energy/gravity" => e.gravity_j,
                "energy/contact" => e.contact_j,
                "energy/dissipated" => e.ledger.dissipated_j(),
                "energy/dissipated_damping" => e.ledger.damping_j,
                "energy/dissipated_drag" => e.ledger.drag_j,
                "energy/dissipated_contact" => e.ledger.contact_j,
                "energy/dissipated_plastic" => e.ledger.plastic_j,
                "energy/collider_work" => e.ledger.collider_work_j,
                "energy/total" => e.total_j(),
                "energy/balance" => e.balance_j(),
                "stats/max_strain" => most.map_or(0.0, |(_, s)| f64::from(s.abs())),
                "stats/step_ms" => st.step_ms,
                "stats/substeps" => f64::from(st.substeps),
                "stats/projections" => f64::from(st.projections),
                "stats/broken_springs" => snap.broken_springs() as f64,
                "stats/cg_iterations" => f64::from(st.solver_iterations),
                "stats/cg_residual" => st.solver_residual,
                _ => f64::NAN,
            }
        };
        for series in SERIES.iter().chain(&MORE_SERIES) {
            // stats/record_ms is logged last, to time the whole frame.
            if self.has(series.when) && series.path != "stats/record_ms" {
                rec.log(series.path, &rerun::Scalars::single(value(series.path)))?;
            }
        }
        // Which spring is the most strained: values beside the plotted number, and a marker in
        // the 3D view.
        if let Some((si, strain)) = most {
            let sp = &m.springs[si];
            let kind = m.spring_kind[si].name();
            let body = m
                .body_of_mass(sp.a)
                .map_or_else(String::new, |(b, _)| b.name.clone());
            let label = format!("strain {strain:+.4}: {kind} spring {si} of {body}");
            rec.log(
                "stats/max_strain",
                &rerun::AnyValues::default()
                    .with_component::<rerun::components::Text>("spring", [label.as_str()])
                    .with_component_from_data(
                        "spring_index",
                        std::sync::Arc::new(rerun::external::arrow::array::UInt32Array::from(
                            vec![si as u32],
                        )),
                    ),
            )?;
            let (a, b) = (snap.positions[sp.a as usize], snap.positions[sp.b as usize]);
            rec.log(
                "world/most_strained",
                &rerun::LineStrips3D::update_fields()
                    .with_strips([[a, b]])
                    .with_labels([label])
                    .with_radii([rerun::Radius::new_ui_points(3.0)]),
            )?;
        }
        Ok(())
    }
}

/// The intact spring with the largest |strain|, and its strain.
pub fn most_strained(strain: &[f32]) -> Option<(usize, f32)> {
    strain
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, s)| !s.is_nan())
        .fold(None, |best: Option<(usize, f32)>, (i, s)| match best {
            Some((_, b)) if b.abs() >= s.abs() => best,
            _ => Some((i, s)),
        })
}
