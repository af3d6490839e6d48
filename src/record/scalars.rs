//! The scalars of a frame: each series' value, and which spring is the most strained (a value
//! beside the plotted number and a marker in the 3D view).

use super::error::RResult;
use super::recorder::Recorder;
use super::series::{When, all_series};
use crate::state::Snapshot;

impl Recorder {
    /// The frame's series; `most` the most strained spring (from the frame's
    /// [`super::StrainSummary`]).
    pub(super) fn log_scalars(&self, snap: &Snapshot, most: Option<(usize, f32)>) -> RResult {
        let (rec, m) = (&self.rec, &self.model);
        let e = &snap.energies;
        let st = &snap.stats;
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
                "stats/newton_iterations" => f64::from(st.newton_iterations),
                "stats/step_residual" => st.rule.map_or(f64::NAN, |r| r.step_residual),
                "stats/unmet_steps" => st.rule.map_or(f64::NAN, |r| f64::from(r.unmet_steps)),
                _ => f64::NAN,
            }
        };
        for series in all_series() {
            // stats/record_ms is logged last, to time the whole frame.
            // The rule's series only where the backend judged the frame (`StepStats::rule`).
            let judged = series.when != When::Solver || st.rule.is_some();
            if self.has(series.when) && judged && series.path != "stats/record_ms" {
                rec.log(
                    self.root.series(series.path),
                    &rerun::Scalars::single(value(series.path)),
                )?;
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
                self.root.series("stats/max_strain"),
                &rerun::AnyValues::default()
                    .with_component::<rerun::components::Text>("spring", [label.as_str()])
                    .with_component_from_data(
                        "spring_index",
                        std::sync::Arc::new(rerun::external::arrow::array::UInt32Array::from(
                            vec![si as u32],
                        )),
                    ),
            )?;
            // The spring, thick, and a thin leader up from its middle to the label, which
            // stands beside the spring rather than over it (on the jello it hid the dent it
            // named).
            let (a, b) = (snap.positions[sp.a as usize], snap.positions[sp.b as usize]);
            let mid = 0.5 * (a + b);
            let tag = mid + glam::Vec3::Y * self.label_rise_m;
            rec.log(
                self.root.world("most_strained"),
                &rerun::LineStrips3D::update_fields()
                    .with_strips([[a, b], [mid, tag]])
                    .with_radii([
                        rerun::Radius::new_ui_points(3.0),
                        rerun::Radius::new_ui_points(0.75),
                    ]),
            )?;
            rec.log(
                self.root.world("most_strained/label"),
                &rerun::Points3D::update_fields()
                    .with_positions([tag])
                    .with_labels([label]),
            )?;
        }
        Ok(())
    }
}
