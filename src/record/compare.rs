//! A comparison's recording: each entry's copy of the scene under `world/<entry>/…` (a
//! [`Recorder`] of its own, rooted there), side by side along x or on top of each other; every
//! copy but the reference also coloured by its distance to the reference at the same simulated
//! time (`world/<entry>/<body>/gap`, on a fixed scale); and the plots that put the entries
//! together, one line per entry: the gap (RMS and max), the total energy and the energy balance,
//! and the wall time per frame.

use std::sync::Arc;

use glam::Vec3;
use rerun::RecordingStream;

use super::compare_layout::{ColourBy, CompareLayout, EntryTally};
use super::error::RResult;
use super::framing::extent;
use super::options::RecordOptions;
use super::palette::{ENTRY_COLORS, Rgb, color, gap_color};
use super::recorder::{Recorder, Root};
use super::shading;
use crate::model::Model;
use crate::scene::settings::Settings;
use crate::state::Snapshot;

struct EntryRec {
    name: String,
    label: String,
    recorder: Recorder,
    colour: Rgb,
    tally: EntryTally,
}

/// An entry's name in entity paths (`world/<path>`) and as the user wrote it.
#[derive(Debug, Clone, PartialEq)]
pub struct EntryName {
    pub path: String,
    pub label: String,
}

/// The recording of a comparison; entry 0 is the reference.
pub struct CompareRecorder {
    rec: RecordingStream,
    model: Arc<Model>,
    entries: Vec<EntryRec>,
    layout: CompareLayout,
    offsets: Vec<Vec3>,
    /// Where each copy's label stands in its own frame: above the middle of the bodies' start,
    /// and in an overlay, each above the last.
    labels_at: Vec<Vec3>,
    gap: Vec<f32>,
    colors: Vec<rerun::Color>,
}

impl CompareRecorder {
    /// A recorder for each of `names` (the reference first) on `rec`.
    pub fn new(
        rec: RecordingStream,
        model: Arc<Model>,
        opts: RecordOptions,
        names: &[EntryName],
        layout: CompareLayout,
    ) -> Self {
        // Side by side along x, one copy's width plus a fifth of the scene's size apart.
        let (lo, hi) = extent(&model.initial.x);
        let size = hi - lo;
        let pitch = size.x + (0.2 * size.max_element()).max(0.1);
        let offsets = (0..names.len())
            .map(|i| {
                if layout.overlay {
                    Vec3::ZERO
                } else {
                    Vec3::new(pitch * i as f32, 0.0, 0.0)
                }
            })
            .collect();
        let entries = names
            .iter()
            .enumerate()
            .map(|(i, n)| EntryRec {
                name: n.path.clone(),
                label: n.label.clone(),
                recorder: Recorder::at(rec.clone(), model.clone(), opts, Root::entry(&n.path)),
                colour: ENTRY_COLORS[i % ENTRY_COLORS.len()],
                tally: EntryTally {
                    name: n.path.clone(),
                    label: n.label.clone(),
                    ..EntryTally::default()
                },
            })
            .collect();
        let above = Vec3::new(0.5 * (lo.x + hi.x), hi.y, 0.5 * (lo.z + hi.z));
        let rise = 0.1 * size.max_element();
        let labels_at = (0..names.len())
            .map(|i| {
                let row = if layout.overlay { i as f32 } else { 0.0 };
                above + Vec3::Y * rise * (1.0 + row)
            })
            .collect();
        Self {
            rec,
            model,
            entries,
            layout,
            offsets,
            labels_at,
            gap: Vec::new(),
            colors: Vec::new(),
        }
    }

    /// What each entry's run came to.
    pub fn tallies(&self) -> Vec<EntryTally> {
        self.entries.iter().map(|e| e.tally.clone()).collect()
    }

    /// The entity paths the 3D view leaves out when the recording opens: each copy's marker of
    /// its most strained spring (one label per copy would cover the copies), and each
    /// non-reference copy's other colouring (in gap colours, its strain-coloured surface and
    /// spring lines).
    fn hidden(&self) -> Vec<String> {
        let hidden: &[&str] = match self.layout.colour_by {
            ColourBy::Gap => &["surface", "springs"],
            ColourBy::Strain => &["gap"],
        };
        let markers = self
            .entries
            .iter()
            .map(|e| format!("world/{}/most_strained/**", e.name));
        let others = self.entries.iter().skip(1).flat_map(|e| {
            self.model.bodies.iter().flat_map(move |b| {
                hidden
                    .iter()
                    .map(move |h| format!("world/{}/{}/{h}", e.name, b.name))
            })
        });
        markers.chain(others).collect()
    }

    /// Everything that does not change: the view's axes, the documents, the layout, each
    /// entry's static data and place, and the plots' lines.
    pub fn log_static(
        &mut self,
        scene_name: &str,
        scene_text: &str,
        settings: &[Settings],
        backend: &str,
    ) -> RResult {
        let rec = self.rec.clone();
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Y_UP())?;
        let lines: Vec<String> = self
            .entries
            .iter()
            .zip(settings)
            .map(|(e, s)| {
                format!(
                    "- `{}` (`world/{}`): {}, dt = {:.3e} s, {} substeps per frame",
                    e.label, e.name, s.integrator, s.dt_secs, s.substeps
                )
            })
            .collect();
        let frames = settings.first().map_or(0, |s| s.frames);
        rec.log_static(
            "scene",
            &rerun::TextDocument::from_markdown(format!(
                "# {scene_name}, compared\n\n{} frames, backend {backend}; the first entry is the \
                 reference.\n\n{}\n\n```toml\n{scene_text}\n```",
                frames,
                lines.join("\n")
            )),
        )?;
        rec.log_static("legend", &rerun::TextDocument::from_markdown(self.legend()))?;
        for (i, e) in self.entries.iter_mut().enumerate() {
            let s = settings.get(i).or(settings.first());
            if let Some(s) = s {
                e.recorder.log_static(scene_name, scene_text, s, backend)?;
            }
            rec.log_static(
                format!("world/{}", e.name),
                &rerun::Transform3D::from_translation(self.offsets[i]),
            )?;
            // The copy's name as the user wrote it, above where it starts, in its plot colour.
            rec.log_static(
                format!("world/{}/label", e.name),
                &rerun::Points3D::new([self.labels_at[i]])
                    .with_labels([e.label.as_str()])
                    .with_colors([rerun::Color::from(e.colour.rgb)])
                    .with_radii([rerun::Radius::new_ui_points(4.0)])
                    .with_show_labels(true),
            )?;
            let line = |path: String, name: String, width: f32| {
                rec.log_static(
                    path,
                    &rerun::SeriesLines::new()
                        .with_names([name])
                        .with_colors([rerun::Color::from(e.colour.rgb)])
                        .with_widths([width]),
                )
            };
            line(
                format!("compare/energy_total/{}", e.name),
                format!("{} total", e.label),
                2.0,
            )?;
            line(
                format!("compare/energy_balance/{}", e.name),
                format!("{} balance", e.label),
                1.0,
            )?;
            line(format!("compare/wall_ms/{}", e.name), e.label.clone(), 1.5)?;
            if i > 0 {
                line(
                    format!("compare/gap_rms/{}", e.name),
                    format!("{} RMS", e.label),
                    2.0,
                )?;
                line(
                    format!("compare/gap_max/{}", e.name),
                    format!("{} max", e.label),
                    1.0,
                )?;
            }
        }
        self.log_gap_statics()?;
        if let (Some(first), ColourBy::Gap) = (self.entries.get(1), self.layout.colour_by) {
            let (lo, hi) = extent(&self.model.initial.x);
            let floor = self
                .model
                .effects
                .ground
                .as_ref()
                .map_or(lo.y, |g| g.height_m);
            super::gap_scale::log_gap_scale(
                &rec,
                &format!("world/{}", first.name),
                (lo, hi),
                floor,
                self.layout.gap_range_m,
            )?;
        }
        super::blueprint::send_comparison_blueprint(&rec, &self.hidden(), self.entries.len() > 1)?;
        Ok(())
    }

    /// The non-reference copies' gap surfaces' triangles, and in an overlay their translucency.
    fn log_gap_statics(&self) -> RResult {
        let translucent = rerun::components::AlbedoFactor(
            rerun::datatypes::Rgba32::from_unmultiplied_rgba(255, 255, 255, 90),
        );
        for e in self.entries.iter().skip(1) {
            for b in &e.recorder.bodies {
                let gap_path = format!("world/{}/{}/gap", e.name, b.name);
                let Some(s) = &b.surface else {
                    let radius = super::statics::point_radius(&self.model, b);
                    self.rec.log_static(
                        gap_path,
                        &rerun::Points3D::update_fields().with_radii([radius]),
                    )?;
                    continue;
                };
                if !s.surface.can_tear {
                    self.rec.log_static(
                        gap_path.as_str(),
                        &rerun::Mesh3D::update_fields()
                            .with_triangle_indices(s.surface.triangles.iter().copied()),
                    )?;
                }
                if self.layout.overlay {
                    for path in [gap_path.as_str(), s.path.as_str()] {
                        self.rec.log_static(
                            path,
                            &rerun::Mesh3D::update_fields().with_albedo_factor(translucent),
                        )?;
                    }
                }
            }
        }
        Ok(())
    }

    /// The legend: the entries, both colour scales, and how to switch between them.
    fn legend(&self) -> String {
        let r = self.layout.gap_range_m;
        let entries: Vec<String> = self
            .entries
            .iter()
            .enumerate()
            .map(|(i, e)| {
                format!(
                    "- `{}`{}: plot lines **{}**",
                    e.label,
                    if i == 0 { " (the reference)" } else { "" },
                    e.colour.name
                )
            })
            .collect();
        let place = if self.layout.overlay {
            "on top of each other, the others translucent over the reference"
        } else {
            "side by side along x, the reference first"
        };
        // Short enough for its panel: the plots name their lines, and the gap's colour bar
        // stands in the 3D view.
        let shown = match self.layout.colour_by {
            ColourBy::Gap => "by gap (`…/gap`; their strain colours, `…/surface`, are hidden)",
            ColourBy::Strain => "by strain (`…/surface`; their gap colours, `…/gap`, are hidden)",
        };
        format!(
            "The same scene under each entry, on the same backend, {place} (each entry's own \
             series: `<entry>/energy/…`, `<entry>/stats/…`):\n\n\
             {}\n\n\
             **Gap**: each mass's distance to the same mass of the reference at the same time: \
             **blue-grey** 0, **amber** {:.3} m, **red** {r:.3} m or more (the bar in the 3D \
             view; `[compare] gap_range_m`). The other copies are coloured {shown}: switch in \
             the blueprint panel, or record with `--colour-by strain`.",
            entries.join("\n"),
            0.5 * r,
        )
    }

    /// One frame: `frame[i]` is entry i's snapshot, `None` for an entry that has stopped.
    pub fn log_frame(&mut self, frame: &[Option<&Snapshot>]) -> RResult {
        for (e, snap) in self.entries.iter_mut().zip(frame) {
            if let Some(s) = snap {
                e.recorder.log_snapshot(s)?;
            }
        }
        let Some(any) = frame.iter().flatten().next() else {
            return Ok(());
        };
        self.rec.set_time_sequence("frame", any.frame as i64);
        self.rec.set_duration_secs("sim_time", any.time_secs);
        let reference = frame.first().copied().flatten();
        for i in 0..self.entries.len() {
            let Some(snap) = frame.get(i).copied().flatten() else {
                continue;
            };
            self.log_entry_scalars(i, snap)?;
            if let (true, Some(r)) = (i > 0, reference) {
                self.log_gap(i, snap, r)?;
            }
        }
        Ok(())
    }

    fn log_entry_scalars(&mut self, i: usize, snap: &Snapshot) -> RResult {
        let e = &mut self.entries[i];
        let en = &snap.energies;
        let t = &mut e.tally;
        t.step_ms += snap.stats.step_ms;
        t.sim_secs = snap.time_secs;
        let balance = en.balance_j();
        if t.balance_j.is_none() {
            // The first frame this entry delivered (frame 0, unless a live view dropped it).
            t.energy_scale_j = en.total_j().abs().max(en.kinetic_j).max(1e-6);
        }
        t.balance_j = Some(
            t.balance_j
                .map_or((balance, balance), |(a, _)| (a, balance)),
        );
        let rec = &self.rec;
        rec.log(
            format!("compare/energy_total/{}", e.name),
            &rerun::Scalars::single(en.total_j()),
        )?;
        rec.log(
            format!("compare/energy_balance/{}", e.name),
            &rerun::Scalars::single(balance),
        )?;
        // Frame 1's time holds what a backend does once (a GPU driver compiling its kernels at
        // their first dispatch: over a second on lavapipe), which would flatten the plot of every
        // later frame: it goes beside the plot, not in it. Frame 0 took no step: no cost to plot.
        let wall = match snap.frame {
            0 => return Ok(()),
            1 => "first_frame_wall_ms",
            _ => "wall_ms",
        };
        rec.log(
            format!("compare/{wall}/{}", e.name),
            &rerun::Scalars::single(snap.stats.step_ms),
        )?;
        Ok(())
    }

    /// Entry `i`'s distance to the reference, mass by mass: its RMS and max, and its copy
    /// coloured by it.
    fn log_gap(&mut self, i: usize, snap: &Snapshot, reference: &Snapshot) -> RResult {
        self.gap.clear();
        self.gap.extend(
            snap.positions
                .iter()
                .zip(&reference.positions)
                .map(|(a, b)| a.distance(*b)),
        );
        let n = self.gap.len().max(1) as f64;
        let rms = (self.gap.iter().map(|g| f64::from(*g).powi(2)).sum::<f64>() / n).sqrt();
        let max = self.gap.iter().copied().fold(0.0f32, f32::max);
        let (rec, range) = (&self.rec, self.layout.gap_range_m);
        let e = &mut self.entries[i];
        e.tally.last_gap_rms_m = Some(rms);
        rec.log(
            format!("compare/gap_rms/{}", e.name),
            &rerun::Scalars::single(rms),
        )?;
        rec.log(
            format!("compare/gap_max/{}", e.name),
            &rerun::Scalars::single(f64::from(max)),
        )?;
        for b in &e.recorder.bodies {
            let path = format!("world/{}/{}/gap", e.name, b.name);
            let gap = &self.gap;
            self.colors.clear();
            match &b.surface {
                Some(s) => {
                    let two_sided = s.surface.two_sided;
                    self.colors
                        .extend(s.surface.vertex_mass.iter().zip(&s.normals).map(
                            |(&m, &normal)| {
                                color(shading::shaded(
                                    gap_color(gap[m as usize], range),
                                    shading::shade(normal, two_sided),
                                ))
                            },
                        ));
                    let mut mesh = rerun::Mesh3D::update_fields()
                        .with_vertex_positions(s.positions.iter().copied())
                        .with_vertex_colors(self.colors.iter().copied());
                    if s.surface.can_tear {
                        mesh = mesh.with_triangle_indices(s.triangles.iter().copied());
                    }
                    rec.log(path, &mesh)?;
                }
                None => {
                    self.colors.extend(
                        gap[b.masses.clone()]
                            .iter()
                            .map(|&g| color(gap_color(g, range))),
                    );
                    rec.log(
                        path,
                        &rerun::Points3D::update_fields()
                            .with_positions(snap.positions[b.masses.clone()].iter().copied())
                            .with_colors(self.colors.iter().copied()),
                    )?;
                }
            }
        }
        Ok(())
    }
}
