//! What a run asks the recording to hold (`--springs`, `--masses`), and what each body then logs.

use super::springs::{self, SpringSelection};
use super::surface;
use crate::model::Model;
use crate::scene::{Scene, View};

/// What a recording holds beyond its defaults (`hooke run --springs … --masses`), and the
/// strain its colours span (the scene's `[view] strain_range`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordOptions {
    /// Which springs are logged as lines; `None`: each body's default for its size
    /// ([`springs::DEFAULT_MAX_SPRINGS`]).
    pub springs: Option<SpringSelection>,
    /// Log the masses of sheets and blocks as points every frame (their surface's vertices are
    /// the same positions; strands always log theirs).
    pub masses: bool,
    /// Strain at the ends of the colour scale: −strain_range fully blue, +strain_range fully red.
    pub strain_range: f32,
    /// How much of a large grid body's surface is recorded (`--surface`).
    pub surface: surface::SurfaceDetail,
}

impl Default for RecordOptions {
    /// The defaults of a scene with no `[view]` table.
    fn default() -> Self {
        Self {
            springs: None,
            masses: false,
            strain_range: View::default().strain_range,
            surface: surface::SurfaceDetail::default(),
        }
    }
}

impl RecordOptions {
    /// These options in the colours `scene` asks for (its `[view] strain_range`).
    pub fn for_scene(self, scene: &Scene) -> Self {
        Self {
            strain_range: scene.view.strain_range,
            ..self
        }
    }
}

/// What each body logs under `opts`, for the start of a run: one line per body.
pub fn describe(model: &Model, opts: &RecordOptions) -> Vec<String> {
    model
        .bodies
        .iter()
        .map(|b| {
            let surface = surface::Surface::of_body(model, b, opts.surface);
            let lines = springs::selected(model, b, opts.springs, surface.is_some()).len();
            let what = match &surface {
                Some(s) if s.stride() > 1 => format!(
                    "surface of {} triangles, one grid vertex in {} along each axis ({} of \
                     {} masses, each coloured by the most strained spring of its block; \
                     --surface full records every vertex)",
                    s.triangles.len(),
                    s.stride(),
                    s.vertex_mass.len(),
                    b.masses.len()
                ),
                Some(s) => format!("surface of {} triangles", s.triangles.len()),
                None => "masses".to_owned(),
            };
            let springs = if lines == 0 && opts.springs.is_none() && !b.springs.is_empty() {
                match springs::is_lattice(b) {
                    // A filled mesh draws the user's surface; its lattice is scaffolding.
                    true => "its lattice's springs left out (the surface shows the body; \
                             --springs structural or all shows them)"
                        .to_owned(),
                    false => format!(
                        "springs left out (more than {} structural; --springs structural or \
                         all shows them)",
                        springs::DEFAULT_MAX_SPRINGS
                    ),
                }
            } else {
                format!("{lines} of {} springs as lines", b.springs.len())
            };
            format!("{}: {what}, {springs}", b.name)
        })
        .collect()
}
