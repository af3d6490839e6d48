//! A point's recording, with what the point was and how it ended as the recording's properties
//! (Rerun's `__properties`): a folder of them, served by `rerun server -d DIR/points`, is one
//! dataset whose segments carry their parameters and results.

use std::path::Path;
use std::sync::Arc;

use rerun::external::arrow::array::{Float64Array, StringArray, UInt64Array};

use crate::error::{Error, Result};
use crate::record::rrd_file::{self, RrdFile};

use super::plan::{Plan, PlannedPoint};
use super::result::PointResult;

/// The recording of a point as it is made.
pub struct PointRecording {
    pub rec: rerun::RecordingStream,
    file: RrdFile,
}

/// Start the recording at `rrd` (a stale one from a killed run is replaced), named after the
/// point and carrying its parameters.
pub fn open(plan: &Plan, point: &PlannedPoint, rrd: &Path) -> Result<PointRecording> {
    let _ = std::fs::remove_file(rrd);
    let _ = std::fs::remove_file(rrd_file::partial_path(rrd));
    let rerun_error =
        |e: rerun::RecordingStreamError| Error::rerun_while("starting a point's recording", e);
    let rec = rerun::RecordingStreamBuilder::new(crate::record::APPLICATION_ID)
        .recording_id(format!("{}-{:04}", plan.id, point.index))
        .send_properties(true)
        .buffered()
        .map_err(rerun_error)?;
    let (sink, file) = rrd_file::create(rrd, true)?;
    rec.set_sink(Box::new(sink));
    rec.send_recording_name(format!("point {:04}: {}", point.index, point.label()))
        .map_err(rerun_error)?;
    let mut sweep = rerun::AnyValues::default()
        .with_component_from_data("sweep_id", text(&plan.id))
        .with_component_from_data("scene", text(&plan.scene))
        .with_component_from_data(
            "index",
            Arc::new(UInt64Array::from(vec![point.index as u64])),
        )
        .with_component_from_data("label", text(&point.label()))
        .with_component_from_data("backend", text(&point.backend));
    for p in &point.params {
        // A parameter's name is never empty (the sweep file's keys are not).
        if let Ok(name) = rerun::ComponentIdentifier::try_new(&p.name) {
            sweep = sweep.with_component_from_data(name, text(&p.value));
        }
    }
    rec.send_property("sweep", &sweep).map_err(rerun_error)?;
    Ok(PointRecording { rec, file })
}

fn text(s: &str) -> Arc<StringArray> {
    Arc::new(StringArray::from(vec![s.to_owned()]))
}

fn number(x: f64) -> Arc<Float64Array> {
    Arc::new(Float64Array::from(vec![x]))
}

impl PointRecording {
    /// Add the point's result (where it has one: not for a point stopped on the way) and end
    /// the file.
    pub fn end(self, result: Option<&PointResult>) -> Result<()> {
        let rerun_error =
            |e: rerun::RecordingStreamError| Error::rerun_while("ending a point's recording", e);
        if let Some(r) = result {
            let mut values = rerun::AnyValues::default()
                .with_component_from_data("status", text(&r.status.to_string()));
            if let Some(m) = &r.message {
                values = values.with_component_from_data("message", text(m));
            }
            let numbers = [
                ("wall_secs", r.wall_secs),
                ("steps_per_sec", r.steps_per_sec),
                ("error_rms_m", r.error_rms_m),
                ("dt_secs", r.dt_secs),
                ("stable_dt_secs", r.stable_dt_secs),
                ("balance_change_j", r.energies.map(|e| e.balance_change_j)),
            ];
            for (name, x) in numbers {
                if let Some(x) = x {
                    values = values.with_component_from_data(name, number(x));
                }
            }
            if let Some(d) = &r.digest {
                values = values.with_component_from_data("digest", text(d));
            }
            self.rec
                .send_property("result", &values)
                .map_err(rerun_error)?;
        }
        self.rec.flush_blocking().map_err(Error::FlushRun)?;
        self.file.finish().map_err(Error::WriteRecording)
    }
}
