//! The default layout a recording opens with, and the settings Rerun's Rust blueprint API cannot
//! express: each plot's legend and the 3D view's eye.

use rerun::RecordingStream;
use rerun::blueprint::components::Corner2D;

use super::error::RResult;
use super::framing::Framing;
use super::series::{Plot, all_series};

/// The application every recording of ours belongs to: the viewer keeps one layout per id.
pub const APPLICATION_ID: &str = "hooke";

/// What a layout sets beyond what Rerun 0.36's Rust blueprint API can: each plot's legend (in
/// a corner, or hidden) and where the 3D view's eye starts.
#[derive(Default)]
struct Properties {
    legends: Vec<(rerun::EntityPath, Option<Corner2D>)>,
    eye: Option<(rerun::EntityPath, Framing)>,
}

/// Where each plot of the default layout names its lines: the corner its lines cross least on
/// the built-in scenes (energy's lines start at the bottom left and the dissipated energy climbs
/// to the top right).
fn legend_corner(plot: Plot) -> Option<Corner2D> {
    match plot {
        Plot::Energy => Some(Corner2D::RightBottom),
        Plot::Strain | Plot::Count => Some(Corner2D::LeftTop),
        Plot::Millis => Some(Corner2D::RightTop),
        Plot::Unplotted => None,
    }
}

/// The default layout: the 3D view beside one plot per unit, the strain histogram and the
/// colour legend, the time panel collapsed to its bar. Returns the layout and its properties.
fn layout(framing: Option<Framing>) -> (rerun::blueprint::Blueprint, Properties) {
    use rerun::blueprint::components::PanelState;
    use rerun::blueprint::{
        BarChartView, Blueprint, ContainerLike, Horizontal, Spatial3DView, TimePanel,
        TimeSeriesView, Vertical,
    };
    let mut props = Properties::default();
    let plots = &mut props.legends;
    let mut plot = |p: Plot| {
        let view: ContainerLike = TimeSeriesView::new(p.title())
            .with_origin("/")
            .with_contents(
                all_series()
                    .filter(|s| s.plot == p)
                    .map(|s| format!("+ /{}", s.path)),
            )
            .into();
        if let ContainerLike::View(v) = &view {
            plots.push((v.blueprint_path(), legend_corner(p)));
        }
        view
    };
    let energy = plot(Plot::Energy);
    let strain = plot(Plot::Strain);
    let millis = plot(Plot::Millis);
    let counts = plot(Plot::Count);
    let histogram: ContainerLike = BarChartView::new("strain histogram")
        .with_origin("/stats/strain_histogram")
        .into();
    // Its bars are one series: nothing to name.
    if let ContainerLike::View(v) = &histogram {
        plots.push((v.blueprint_path(), None));
    }
    let world: ContainerLike = Spatial3DView::new("world").with_origin("/world").into();
    if let (ContainerLike::View(v), Some(f)) = (&world, framing) {
        props.eye = Some((v.blueprint_path(), f));
    }
    let blueprint = Blueprint::new(
        Horizontal::new([
            world,
            Vertical::new([
                energy,
                Horizontal::new([strain, histogram]).into(),
                Horizontal::new([millis, counts]).into(),
                documents(),
            ])
            // The energy plot names up to 12 lines in its legend: at 0.34 of the column its
            // legend ran past the plot's foot at 1600 × 900 and hid gravity, kinetic and total.
            .with_row_shares([0.44, 0.2, 0.2, 0.16])
            .into(),
        ])
        .with_column_shares([0.6, 0.4]),
    )
    .with_time_panel(TimePanel::new().with_state(PanelState::Collapsed))
    .with_auto_views(false)
    .with_selection_panel(rerun::blueprint::SelectionPanel::from_state(
        PanelState::Collapsed,
    ))
    .with_blueprint_panel(rerun::blueprint::BlueprintPanel::from_state(
        PanelState::Collapsed,
    ));
    (blueprint, props)
}

/// The legend and scene documents, and the run's warnings (each run's `notes`, a comparison's
/// entries' too), as tabs.
fn documents() -> rerun::blueprint::ContainerLike {
    use rerun::blueprint::{Tabs, TextDocumentView, TextLogView};
    Tabs::new([
        TextDocumentView::new("legend")
            .with_origin("/legend")
            .into(),
        TextDocumentView::new("scene").with_origin("/scene").into(),
        TextLogView::new("warnings").with_origin("/").into(),
    ])
    .into()
}

/// Sends the default layout to `rec`, made active at once, its 3D view's eye on `framing`
/// where given (else where the viewer puts it).
///
/// Each plot names its lines in a legend in one corner (a click on a name hides its line); each
/// series also has a fixed colour, named in the `legend` document. Rerun 0.36's Rust blueprint
/// API cannot set a view's legend or eye, so those properties are logged into the blueprint's
/// own store beside the layout, as the viewer reads them.
pub fn send_blueprint(rec: &RecordingStream, framing: Option<Framing>, takes: Takes) -> RResult {
    let (blueprint, props) = layout(framing);
    send_layout(rec, blueprint, &props, takes)
}

/// How a layout takes effect in a viewer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Takes {
    /// At once, and as the default a reset returns to: a recording opened later shows it.
    Now,
    /// As the default only: a viewer watching the run keeps its view (its eye where the user put
    /// it) until its layout is reset.
    AsDefault,
}

impl Takes {
    /// The layout framed on a whole run, sent at its end, for a run recorded to a live viewer
    /// (`Some(with a file beside it)`) or not (`None`: a file, a pipe, a server). A viewer alone
    /// keeps the view its user has rather than jumping to the new eye; wherever a file is
    /// written, the framing takes effect, so that the file opens with it.
    pub fn at_run_end(viewer_with_file: Option<bool>) -> Self {
        match viewer_with_file {
            Some(false) => Takes::AsDefault,
            Some(true) | None => Takes::Now,
        }
    }
}

/// A comparison's layout: every copy in one 3D view (the paths in `hidden` left out: each copy's
/// other colouring), beside the plots that put the entries together (the gap's only when
/// `with_gap`: there is an entry beside the reference) and the documents.
pub fn send_comparison_blueprint(
    rec: &RecordingStream,
    hidden: &[String],
    with_gap: bool,
) -> RResult {
    use rerun::blueprint::components::PanelState;
    use rerun::blueprint::{
        Blueprint, ContainerLike, Horizontal, Spatial3DView, TimeSeriesView, Vertical,
    };
    let mut props = Properties::default();
    // One line per entry, in its copy's colour: the legend names the entries.
    let mut plot = |title: &str, contents: &[&str]| {
        let view: ContainerLike = TimeSeriesView::new(title)
            .with_origin("/")
            .with_contents(contents.iter().map(|c| format!("+ /{c}/**")))
            .into();
        if let ContainerLike::View(v) = &view {
            props
                .legends
                .push((v.blueprint_path(), Some(Corner2D::LeftTop)));
        }
        view
    };
    let mut column = Vec::new();
    if with_gap {
        column.push(plot(
            "gap to the reference (m)",
            &["compare/gap_rms", "compare/gap_max"],
        ));
    }
    column.push(plot(
        "energy (J)",
        &["compare/energy_total", "compare/energy_balance"],
    ));
    // Frame 1, with one-off costs, is at compare/first_frame_wall_ms (docs/guide/compare.md); a longer title
    // is cut off in the panel.
    column.push(plot(
        "wall time per frame (ms, from frame 2)",
        &["compare/wall_ms"],
    ));
    column.push(documents());
    let world = Spatial3DView::new("world")
        .with_origin("/world")
        .with_contents(
            std::iter::once("+ /world/**".to_owned())
                .chain(hidden.iter().map(|h| format!("- /{h}"))),
        );
    // A comparison opens at its latest frame, on simulated time: the plots show the whole run
    // and the copies as far apart as they got; scrub back from there.
    let time = rerun::blueprint::TimePanel::new()
        .with_state(PanelState::Collapsed)
        .with_timeline("sim_time")
        .with_play_state(rerun::blueprint::components::PlayState::Following);
    let blueprint = Blueprint::new(
        Horizontal::new([world.into(), Vertical::new(column).into()])
            .with_column_shares([0.62, 0.38]),
    )
    .with_time_panel(time)
    .with_auto_views(false)
    .with_selection_panel(rerun::blueprint::SelectionPanel::from_state(
        PanelState::Collapsed,
    ))
    .with_blueprint_panel(rerun::blueprint::BlueprintPanel::from_state(
        PanelState::Collapsed,
    ));
    send_layout(rec, blueprint, &props, Takes::Now)
}

/// `blueprint` sent to `rec` with its `props`, taking effect as `takes` says.
fn send_layout(
    rec: &RecordingStream,
    blueprint: rerun::blueprint::Blueprint,
    props: &Properties,
    takes: Takes,
) -> RResult {
    use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreKind};
    use rerun::external::re_sdk_types::blueprint::archetypes::{EyeControls3D, PlotLegend};
    let activation = rerun::blueprint::BlueprintActivation {
        make_active: takes == Takes::Now,
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
    // The properties, logged into that same blueprint store.
    let (store, prop_msgs) = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(blueprint_id.recording_id().clone())
        .blueprint()
        .memory()?;
    store.set_time_sequence("blueprint", 0);
    for (view, corner) in &props.legends {
        let legend = match corner {
            Some(c) => PlotLegend::new().with_visible(true).with_corner(*c),
            None => PlotLegend::new().with_visible(false),
        };
        store.log(format!("{view}/PlotLegend"), &legend)?;
    }
    if let Some((view, f)) = &props.eye {
        store.log(
            format!("{view}/EyeControls3D"),
            &EyeControls3D::new()
                .with_position(f.eye_m.to_array())
                .with_look_target(f.target_m.to_array())
                .with_eye_up([0.0, 1.0, 0.0]),
        )?;
    }
    msgs.extend(
        prop_msgs
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_live_viewer_alone_keeps_its_view_at_the_end() {
        assert_eq!(Takes::at_run_end(Some(false)), Takes::AsDefault);
        assert_eq!(Takes::at_run_end(Some(true)), Takes::Now);
        assert_eq!(Takes::at_run_end(None), Takes::Now);
    }
}
