//! `world/<body>/springs`: the springs as line segments coloured by strain, built each frame from
//! one flat buffer of coordinates (no allocation per spring), with per-instance values that the
//! viewer shows when a spring is hovered: `strain` each frame, `kind` and `rest_length_m` once.

use std::sync::Arc;

use rerun::external::arrow;
use rerun::external::arrow::array::{FixedSizeListArray, Float32Array, ListArray, StringArray};
use rerun::external::arrow::buffer::{OffsetBuffer, ScalarBuffer};
use rerun::{AsComponents as _, Loggable as _, SerializedComponentBatch};

use crate::model::{BodyInfo, BodyShape, MeshVertices, Model, SpringKindTag};
use crate::state::Snapshot;

/// Which springs are logged as lines (`--springs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SpringSelection {
    /// Every spring: structural, shear and bending.
    All,
    /// Only the structural springs (along the grid).
    Structural,
    /// None: the surface (sheets and blocks) or the masses (strands) only.
    None,
}

/// A sheet or block logs its structural springs by default when it has at most this many (and
/// none when it has more). Measured (BENCHMARKS.md, "Recording"): a structural spring costs about
/// 21 bytes per frame in an .rrd (two endpoints, a colour and its strain, compressed), so this
/// many cost about 100 KB, a whole small scene's frame. cloth (1 984 structural springs) and
/// jello (2 700) log theirs; cloth-64 (8 064) and larger do not.
pub const DEFAULT_MAX_SPRINGS: usize = 5_000;

/// The springs of `body` that are logged under `selection` (`None`: the default).
///
/// The default: a strand (no surface) shows all its springs, since they are its picture. A sheet
/// or block shows its structural springs, the grid drawn over its surface, when it has at most
/// [`DEFAULT_MAX_SPRINGS`]; its shear and bending springs are left out, as they lie across a
/// sheet's quads or inside a block, where the surface hides them, and would double the bytes
/// (cloth: 60 KB per frame with structural springs, 123 KB with all). A body built by hand
/// with no structural springs counts all of its springs instead.
pub fn selected(
    model: &Model,
    body: &BodyInfo,
    selection: Option<SpringSelection>,
    has_surface: bool,
) -> Vec<u32> {
    let all = || body.springs.clone().collect::<Vec<u32>>();
    let structural = || {
        body.springs
            .clone()
            .filter(|&s| model.spring_kind[s as usize] == SpringKindTag::Structural)
            .collect::<Vec<u32>>()
    };
    match selection {
        Some(SpringSelection::All) => all(),
        Some(SpringSelection::Structural) => structural(),
        Some(SpringSelection::None) => Vec::new(),
        None if !has_surface => all(),
        // A filled mesh draws the user's surface; its lattice is scaffolding.
        None if is_lattice(body) => Vec::new(),
        None => {
            let s = structural();
            let s = if s.is_empty() { all() } else { s };
            if s.len() <= DEFAULT_MAX_SPRINGS {
                s
            } else {
                Vec::new()
            }
        }
    }
}

/// Whether `body` is a mesh filled with a lattice (its surface embedded in the lattice's cells).
pub fn is_lattice(body: &BodyInfo) -> bool {
    matches!(&body.shape, BodyShape::Mesh(m) if matches!(m.vertices, MeshVertices::Embedded(_)))
}

/// One body's logged springs and the buffers their frame is built in.
pub struct SpringLines {
    pub path: String,
    /// Spring indices (model-wide), one line instance each, in this order every frame.
    pub springs: Vec<u32>,
    colors: Vec<rerun::Color>,
}

impl SpringLines {
    pub fn new(path: String, springs: Vec<u32>) -> Self {
        let colors = Vec::with_capacity(springs.len());
        Self {
            path,
            springs,
            colors,
        }
    }

    /// What never changes: the kind and rest length of each instance, for hovering, and the line
    /// radius. (A plastic spring's rest length changes; the value shown is the one it started
    /// with, and the legend says so.)
    pub fn static_batches(&self, model: &Model, radius: f32) -> Vec<SerializedComponentBatch> {
        let kinds = StringArray::from_iter_values(
            self.springs
                .iter()
                .map(|&s| model.spring_kind[s as usize].name()),
        );
        let rest = Float32Array::from_iter_values(
            self.springs
                .iter()
                .map(|&s| model.springs[s as usize].rest_m),
        );
        let mut out = rerun::AnyValues::default()
            .with_component_from_data("kind", Arc::new(kinds))
            .with_component_from_data("rest_length_m", Arc::new(rest))
            .as_serialized_batches();
        out.extend(
            rerun::LineStrips3D::update_fields()
                .with_radii([radius])
                .as_serialized_batches(),
        );
        out
    }

    /// This frame's lines, colours and strains. A broken spring keeps its instance (so that the
    /// static kind and rest length stay aligned) as an empty strip: nothing is drawn.
    pub fn frame_batches(
        &mut self,
        snap: &Snapshot,
        model: &Model,
        color: impl Fn(f32) -> rerun::Color,
    ) -> Result<Vec<SerializedComponentBatch>, super::error::RecordError> {
        let n = self.springs.len();
        let mut coords: Vec<f32> = Vec::with_capacity(6 * n);
        let mut offsets: Vec<i32> = Vec::with_capacity(n + 1);
        let mut strains: Vec<f32> = Vec::with_capacity(n);
        self.colors.clear();
        offsets.push(0);
        for &s in &self.springs {
            let strain = snap.strain[s as usize];
            strains.push(strain);
            self.colors.push(color(strain));
            if !strain.is_nan() {
                let sp = &model.springs[s as usize];
                let (a, b) = (snap.positions[sp.a as usize], snap.positions[sp.b as usize]);
                coords.extend_from_slice(&[a.x, a.y, a.z, b.x, b.y, b.z]);
            }
            offsets.push((coords.len() / 3) as i32);
        }
        let mut out = vec![SerializedComponentBatch::new(
            strips_array(coords, offsets)?,
            rerun::LineStrips3D::descriptor_strips(),
        )];
        out.extend(
            rerun::LineStrips3D::update_fields()
                .with_colors(self.colors.iter().copied())
                .as_serialized_batches(),
        );
        out.extend(
            rerun::AnyValues::default()
                .with_component_from_data("strain", Arc::new(Float32Array::from(strains)))
                .as_serialized_batches(),
        );
        Ok(out)
    }
}

/// Line strips as Rerun's `LineStrip3D` arrow layout (a list of 3-float points per strip) built
/// from flat coordinates and point offsets, without a `Vec` per strip.
fn strips_array(
    coords: Vec<f32>,
    offsets: Vec<i32>,
) -> Result<arrow::array::ArrayRef, super::error::RecordError> {
    use super::error::LayoutError;
    let arrow::datatypes::DataType::List(list_field) =
        rerun::components::LineStrip3D::arrow_datatype()
    else {
        return Err(LayoutError::NotAList.into());
    };
    let arrow::datatypes::DataType::FixedSizeList(point_field, 3) = list_field.data_type().clone()
    else {
        return Err(LayoutError::NotThreeFloats.into());
    };
    let points =
        FixedSizeListArray::try_new(point_field, 3, Arc::new(Float32Array::from(coords)), None)
            .map_err(LayoutError::from)?;
    let strips = ListArray::try_new(
        list_field,
        OffsetBuffer::new(ScalarBuffer::from(offsets)),
        Arc::new(points),
        None,
    )
    .map_err(LayoutError::from)?;
    Ok(Arc::new(strips))
}
