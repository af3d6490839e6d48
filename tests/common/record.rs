//! Recordings made in-process by hooke's recorder, and read back component by component with
//! Rerun's own decoder.

use hooke::integrator::Step;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use hooke::backend::Backend as _;
use hooke::model::Model;
use hooke::record::{RecordOptions, Recorder};
use hooke::state::Snapshot;
use rerun::external::arrow::array::{Array as _, ArrayRef};
use rerun::log::{Chunk, LogMsg};

/// One logged row of a component: its frame (`None`: static) and its values.
pub type Rows = Vec<(Option<i64>, ArrayRef)>;

/// Decode an .rrd with Rerun's decoder: per (entity, component), every row logged.
pub fn read_components(path: &Path) -> BTreeMap<(String, String), Rows> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out: BTreeMap<(String, String), Rows> = BTreeMap::new();
    for msg in re_log_encoding::DecoderApp::decode_lazy(std::io::BufReader::new(file)) {
        let msg = msg.unwrap_or_else(|e| panic!("decoding {}: {e}", path.display()));
        let LogMsg::ArrowMsg(_, arrow) = msg else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).unwrap_or_else(|e| panic!("{e}"));
        let frames = chunk
            .timelines()
            .iter()
            .find(|(name, _)| name.as_str() == "frame")
            .map(|(_, col)| col.times_raw().to_vec());
        for id in chunk.components_identifiers() {
            let Some(list) = chunk.components().get_array(id) else {
                continue;
            };
            let rows = out
                .entry((chunk.entity_path().to_string(), id.to_string()))
                .or_default();
            for i in 0..list.len() {
                if list.is_valid(i) {
                    let frame = frames.as_ref().map(|f| f[i]);
                    rows.push((frame, list.value(i)));
                }
            }
        }
    }
    out
}

/// The row of `component` on `entity` in force at `frame` (the latest at or before it, or static).
pub fn at_frame<'a>(
    c: &'a BTreeMap<(String, String), Rows>,
    entity: &str,
    component: &str,
    frame: i64,
) -> &'a ArrayRef {
    let rows = c
        .get(&(entity.to_owned(), component.to_owned()))
        .unwrap_or_else(|| {
            panic!(
                "no {component} on {entity}; have {:?}",
                c.keys().filter(|(e, _)| e == entity).collect::<Vec<_>>()
            )
        });
    rows.iter()
        .filter(|(f, _)| f.is_none_or(|f| f <= frame))
        .max_by_key(|(f, _)| f.unwrap_or(i64::MIN))
        .map(|(_, a)| a)
        .unwrap_or_else(|| panic!("{entity} {component}: nothing at frame {frame}"))
}

/// A scene's model, stepped `frames` frames on the CPU, and the snapshots of frame 0 and the last.
pub fn stepped(scene: &str, frames: u64) -> (hooke::scene::LoadedScene, Arc<Model>, Vec<Snapshot>) {
    let hooke::run::prepare::Planned {
        loaded,
        settings,
        model,
    } = hooke::run::prepare::planned(scene).unwrap_or_else(|e| panic!("{e}"));
    let mut be = hooke::cpu::CpuBackend::new(
        model.clone(),
        Step::new(settings.integrator, settings.dt_secs),
    );
    let first = be
        .snapshot(0, Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    for _ in 0..frames {
        be.advance(settings.substeps)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let last = be
        .snapshot(frames, Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    (loaded, model, vec![first, last])
}

/// Record `snaps` with the hooke recorder into `path`.
pub fn record(
    loaded: &hooke::scene::LoadedScene,
    model: &Arc<Model>,
    snaps: &[Snapshot],
    opts: RecordOptions,
    path: &Path,
) {
    let settings = hooke::scene::settings::Settings::resolve(&loaded.scene, &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let rec = rerun::RecordingStreamBuilder::new("hooke-test")
        .save(path)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut r = Recorder::new(rec.clone(), model.clone(), opts.for_scene(&loaded.scene));
    r.log_static(&loaded.scene.name, &loaded.text, &settings, "test")
        .unwrap_or_else(|e| panic!("{e}"));
    for s in snaps {
        r.log_snapshot(s).unwrap_or_else(|e| panic!("{e}"));
    }
    drop(r);
    rec.flush_blocking().unwrap_or_else(|e| panic!("{e}"));
}

/// Every (entity, component) of a recording that holds a NaN or an infinity in any of its float
/// values, at any frame: none may ever reach a recording.
pub fn non_finite_components(path: &Path) -> Vec<(String, String)> {
    read_components(path)
        .into_iter()
        .filter(|(_, rows)| rows.iter().any(|(_, array)| !all_finite(array.as_ref())))
        .map(|(key, _)| key)
        .collect()
}

fn all_finite(array: &dyn rerun::external::arrow::array::Array) -> bool {
    use rerun::external::arrow::array::{
        FixedSizeListArray, Float32Array, Float64Array, ListArray, StructArray,
    };
    let any = array.as_any();
    if let Some(a) = any.downcast_ref::<Float32Array>() {
        a.iter().flatten().all(f32::is_finite)
    } else if let Some(a) = any.downcast_ref::<Float64Array>() {
        a.iter().flatten().all(f64::is_finite)
    } else if let Some(a) = any.downcast_ref::<FixedSizeListArray>() {
        all_finite(a.values().as_ref())
    } else if let Some(a) = any.downcast_ref::<ListArray>() {
        all_finite(a.values().as_ref())
    } else if let Some(a) = any.downcast_ref::<StructArray>() {
        a.columns().iter().all(|c| all_finite(c.as_ref()))
    } else {
        true
    }
}
