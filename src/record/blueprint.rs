//! The default layout a recording opens with, and the legend settings Rerun's Rust blueprint API
//! cannot express.

use rerun::RecordingStream;

use super::error::RResult;
use super::series::{Plot, all_series};

/// The application every recording of ours belongs to: the viewer keeps one layout per id.
pub const APPLICATION_ID: &str = "hooke";

/// The default layout: the 3D view beside one plot per unit, the strain histogram and the
/// colour legend. Returns the layout and the blueprint paths of its plots (the histogram's
/// included).
fn layout() -> (rerun::blueprint::Blueprint, Vec<rerun::EntityPath>) {
    use rerun::blueprint::components::PanelState;
    use rerun::blueprint::{
        BarChartView, Blueprint, ContainerLike, Horizontal, Spatial3DView, TimeSeriesView, Vertical,
    };
    let mut plots = Vec::new();
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
            plots.push(v.blueprint_path());
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
                documents(),
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

/// Sends the default layout to `rec`, made active at once.
///
/// Its plots have no legend inside them: a legend is drawn over the plot, and in plots this
/// size it hides the data. Each series has a fixed colour instead, named in the `legend`
/// document, and the viewer names a line when it is hovered. Rerun 0.36's Rust blueprint API
/// cannot set a view's legend, so the legend properties are logged into the blueprint's own
/// store beside the layout, as the viewer reads them.
pub fn send_blueprint(rec: &RecordingStream) -> RResult {
    let (blueprint, plots) = layout();
    send_layout(rec, blueprint, &plots)
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
    let mut plots = Vec::new();
    let mut plot = |title: &str, contents: &[&str]| {
        let view: ContainerLike = TimeSeriesView::new(title)
            .with_origin("/")
            .with_contents(contents.iter().map(|c| format!("+ /{c}/**")))
            .into();
        if let ContainerLike::View(v) = &view {
            plots.push(v.blueprint_path());
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
    send_layout(rec, blueprint, &plots)
}

/// `blueprint` sent to `rec`, made active at once, with the legends of `plots` hidden.
fn send_layout(
    rec: &RecordingStream,
    blueprint: rerun::blueprint::Blueprint,
    plots: &[rerun::EntityPath],
) -> RResult {
    use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, StoreKind};
    use rerun::external::re_sdk_types::blueprint::archetypes::PlotLegend;
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
    for view in plots {
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
