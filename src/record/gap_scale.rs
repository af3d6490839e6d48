//! A comparison's gap colour bar, drawn in the 3D view in front of a copy coloured by its gap:
//! the scale from 0 to the range, in the colours the copies take, with its ends and middle
//! labelled (Rerun 0.36 has no colour bar of its own to attach to a mesh).

use glam::Vec3;
use rerun::RecordingStream;

use super::error::RResult;
use super::palette::gap_color;

/// Segments of the bar: enough that the blend from blue-grey through amber to red reads.
const SEGMENTS: usize = 20;

/// Logs the bar under `parent` (a copy's root, whose place it takes), static: from `lo.x` to
/// `hi.x` of the bodies' start, just in front of them (+z) at `floor_y`.
pub fn log_gap_scale(
    rec: &RecordingStream,
    parent: &str,
    (lo, hi): (Vec3, Vec3),
    floor_y: f32,
    range_m: f32,
) -> RResult {
    let size = (hi - lo).max_element().max(1e-3);
    let z = hi.z + 0.15 * size;
    let at = |t: f32| Vec3::new(lo.x + t * (hi.x - lo.x), floor_y, z);
    let ts: Vec<f32> = (0..=SEGMENTS).map(|k| k as f32 / SEGMENTS as f32).collect();
    let strips: Vec<[Vec3; 2]> = ts.windows(2).map(|w| [at(w[0]), at(w[1])]).collect();
    let colors: Vec<rerun::Color> = ts
        .windows(2)
        .map(|w| {
            let [r, g, b] = gap_color(0.5 * (w[0] + w[1]) * range_m, range_m);
            rerun::Color::from_rgb(r, g, b)
        })
        .collect();
    rec.log_static(
        format!("{parent}/gap_scale"),
        &rerun::LineStrips3D::new(strips)
            .with_colors(colors)
            .with_radii([rerun::Radius::new_ui_points(6.0)]),
    )?;
    let ticks = [0.0f32, 0.5, 1.0];
    let labels = ticks.map(|t| {
        let gap = t * range_m;
        let text = if gap < 0.01 && gap > 0.0 {
            format!("{:.1} mm", 1e3 * gap)
        } else if gap < 1.0 && gap > 0.0 {
            format!("{:.1} cm", 1e2 * gap)
        } else {
            format!("{gap} m")
        };
        if t == 1.0 {
            format!("gap ≥ {text}")
        } else {
            format!("gap {text}")
        }
    });
    rec.log_static(
        format!("{parent}/gap_scale/ticks"),
        &rerun::Points3D::new(ticks.map(at))
            .with_labels(labels)
            .with_colors(ticks.map(|t| {
                let [r, g, b] = gap_color(t * range_m, range_m);
                rerun::Color::from_rgb(r, g, b)
            }))
            .with_radii([rerun::Radius::new_ui_points(3.0)])
            .with_show_labels(true),
    )?;
    Ok(())
}
