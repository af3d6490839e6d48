//! The `Recorder`: the state a recording keeps between frames, and one frame's logging — each
//! body's masses and surface, its spring lines, the moving colliders, the scalars and the strain
//! histogram. What is logged once is in `statics`; the scalars in `scalars`.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use rerun::RecordingStream;

use super::error::RResult;
use super::framing::{Framing, Visited};
use super::options::RecordOptions;
use super::palette::{color, strain_color};
use super::series::When;
use super::shading;
use super::springs;
use super::strain_summary::StrainSummary;
use super::surface;
use crate::model::{Model, Shape};
use crate::state::Snapshot;

/// One body as it is recorded.
pub(super) struct BodyRec {
    pub(super) name: String,
    pub(super) masses: std::ops::Range<usize>,
    pub(super) springs: std::ops::Range<usize>,
    pub(super) surface: Option<SurfaceRec>,
    pub(super) lines: Option<springs::SpringLines>,
    /// Log the masses as points every frame.
    pub(super) masses_per_frame: bool,
}

/// A body's surface and the buffers a frame is built in.
pub(super) struct SurfaceRec {
    pub(super) path: String,
    pub(super) surface: surface::Surface,
    /// The vertices are the body's masses in order: positions are a slice of the snapshot's.
    whole_body: bool,
    /// The triangles drawn now, and the broken springs of the body when they were chosen.
    pub(super) triangles: Vec<[u32; 3]>,
    broken: Option<usize>,
    /// The last frame's vertices and their normals (a comparison colours them again by gap).
    pub(super) positions: Vec<Vec3>,
    pub(super) normals: Vec<Vec3>,
    strain: Vec<f32>,
    colors: Vec<rerun::Color>,
}

/// Where a recorder logs: a run's entities at the top (`world/…`, `energy/…`), or one entry of a
/// comparison under the entry's name (`world/<entry>/…`, `<entry>/energy/…`), the documents
/// and the view's coordinates then left to the comparison.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Root {
    entry: Option<String>,
}

impl Root {
    /// One entry of a comparison, named `name`.
    pub fn entry(name: &str) -> Self {
        Self {
            entry: Some(name.to_owned()),
        }
    }

    /// `world/<rest>`, under the entry's name when there is one.
    pub fn world(&self, rest: &str) -> String {
        match &self.entry {
            None => format!("world/{rest}"),
            Some(e) => format!("world/{e}/{rest}"),
        }
    }

    /// A series' path (`energy/total`), under the entry's name when there is one.
    pub fn series(&self, path: &str) -> String {
        match &self.entry {
            None => path.to_owned(),
            Some(e) => format!("{e}/{path}"),
        }
    }

    /// The recording is this recorder's alone: it logs the documents and the view's axes.
    pub fn is_whole(&self) -> bool {
        self.entry.is_none()
    }
}

/// Turns snapshots into Rerun entities; keeps what a frame needs from the last (the triangles
/// drawn, the histogram, the buffers a frame is built in).
pub struct Recorder {
    pub(super) rec: RecordingStream,
    pub(super) model: std::sync::Arc<Model>,
    pub(super) strain_range: f32,
    /// The springs the most strained one is taken from (`strain_summary::labelled_springs`).
    pub(super) labelled: Option<std::sync::Arc<[bool]>>,
    pub(super) root: Root,
    pub(super) bodies: Vec<BodyRec>,
    /// The implicit integrator's solver statistics are logged too.
    pub(super) implicit: bool,
    /// The run's solver has an acceptance rule (implicit Euler, BDF2, VBD): its residual and
    /// its steps short of the rule are logged too.
    pub(super) solver: bool,
    /// `world/colliders/<kind>_<k>`, k counting colliders of one kind.
    pub(super) collider_paths: Vec<String>,
    /// `--springs` was not given: each body logs its default.
    pub(super) default_springs: bool,
    /// How far above its spring the most strained spring's label stands: a quarter of the
    /// bodies' starting size.
    pub(super) label_rise_m: f32,
    /// Where the bodies have been, for the 3D view's eye at the end of the run.
    visited: Visited,
}

impl Recorder {
    pub fn new(rec: RecordingStream, model: std::sync::Arc<Model>, opts: RecordOptions) -> Self {
        Self::at(rec, model, opts, Root::default())
    }

    /// [`Recorder::new`], logging under `root`.
    pub fn at(
        rec: RecordingStream,
        model: std::sync::Arc<Model>,
        opts: RecordOptions,
        root: Root,
    ) -> Self {
        let mut counts = std::collections::HashMap::new();
        let collider_paths = model
            .effects
            .colliders
            .iter()
            .map(|c| {
                let k = counts.entry(c.kind()).or_insert(0);
                *k += 1;
                root.world(&format!("colliders/{}_{}", c.kind(), *k - 1))
            })
            .collect();
        let bodies = model
            .bodies
            .iter()
            .map(|b| {
                let surface =
                    surface::Surface::of_body(&model, b, opts.surface).map(|s| SurfaceRec {
                        path: root.world(&format!("{}/surface", b.name)),
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
                        springs::SpringLines::new(
                            root.world(&format!("{}/springs", b.name)),
                            selected,
                        )
                    }),
                    surface,
                }
            })
            .collect();
        let (lo, hi) = super::framing::extent(&model.initial.x);
        let label_rise_m = (0.25 * (hi - lo).max_element()).clamp(0.02, 2.0);
        Self {
            rec,
            label_rise_m,
            visited: Visited::default(),
            labelled: super::strain_summary::labelled_springs(&model),
            model,
            strain_range: opts.strain_range,
            root,
            bodies,
            implicit: false,
            solver: false,
            collider_paths,
            default_springs: opts.springs.is_none(),
        }
    }

    pub(super) fn has(&self, when: When) -> bool {
        match when {
            When::Always => true,
            When::SpringsChange => self.model.effects.springs_change(),
            When::Tearing => self.model.effects.tearing,
            When::Implicit => self.implicit,
            When::Solver => self.solver,
        }
    }

    /// Frames a whole recording's 3D view on every place its bodies went, once its frames are
    /// logged: the layout is sent again with that eye, taking effect as `takes` says; a
    /// recording opened afterwards shows it.
    pub fn frame_what_was_seen(&self, takes: super::blueprint::Takes) -> RResult {
        match (
            self.root.is_whole(),
            Framing::over_run(&self.model, &self.visited),
        ) {
            (true, Some(f)) => super::blueprint::send_blueprint(&self.rec, Some(f), takes),
            _ => Ok(()),
        }
    }

    /// One frame on both timelines.
    pub fn log_snapshot(&mut self, snap: &Snapshot) -> RResult {
        let started = Instant::now();
        self.rec.set_time_sequence("frame", snap.frame as i64);
        self.rec.set_duration_secs("sim_time", snap.time_secs);
        self.visited.see(&snap.positions);
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
        // Made on the simulation thread when a digest stage ran there; here otherwise.
        let (most, counts) = match &snap.digest {
            Some(d) => (d.most, d.histogram.clone()),
            None => {
                let s = StrainSummary::of(&snap.strain, range, self.labelled.as_deref());
                (s.most, s.counts)
            }
        };
        self.log_scalars(snap, most)?;
        self.rec.log(
            self.root.series("stats/strain_histogram"),
            &rerun::BarChart::update_fields().with_values(counts),
        )?;
        self.rec.log(
            self.root.series("stats/record_ms"),
            &rerun::Scalars::single(started.elapsed().as_secs_f64() * 1e3),
        )?;
        // The run's warnings, on the timeline at the frame where each first held.
        for note in &snap.notes {
            self.rec.log(
                self.root.series("notes"),
                &rerun::TextLog::new(note.to_string()).with_level(rerun::TextLogLevel::WARN),
            )?;
        }
        Ok(())
    }

    /// A body's masses and surface for one frame.
    fn log_body(&mut self, bi: usize, snap: &Snapshot) -> RResult {
        let (rec, m, b) = (&self.rec, &self.model, &mut self.bodies[bi]);
        let pos = &snap.positions[b.masses.clone()];
        if b.masses_per_frame {
            rec.log(
                self.root.world(&format!("{}/masses", b.name)),
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
        if s.whole_body {
            s.positions.clear();
            s.positions.extend_from_slice(pos);
        } else {
            s.surface.positions(&snap.positions, &mut s.positions);
        }
        shading::vertex_normals(&s.positions, &s.triangles, &mut s.normals);
        match snap.digest.as_ref().and_then(|d| d.surfaces.get(bi)) {
            Some(made) if !made.is_empty() => s.strain.clone_from(made),
            _ => s.surface.strain(m, &snap.strain, &mut s.strain),
        }
        let two_sided = s.surface.two_sided;
        let range = self.strain_range;
        s.colors.clear();
        s.colors
            .par_extend(s.strain.par_iter().zip(&s.normals).map(|(&strain, &n)| {
                color(shading::shaded(
                    strain_color(strain, range),
                    shading::shade(n, two_sided),
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
}
