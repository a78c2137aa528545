//! A small writer of rerun blueprints: containers and views, and the view properties
//! (time axis, legend, scalar axis, visible time ranges) that rerun's Rust blueprint API
//! (0.36) does not expose yet.
//!
//! The layout is logged into a blueprint store as the viewer reads it — the same
//! entities and archetypes the SDK's own `Blueprint::send` writes (`viewport`,
//! `container/<id>`, `view/<id>`, `view/<id>/ViewContents`), plus one entity per view
//! property (`view/<id>/TimeAxis`, ...), the layout Python's `rerun.blueprint` writes.

use crate::sdk::external::re_log_types::{BlueprintActivationCommand, LogMsg, RecordingId};
use crate::sdk::types::blueprint::archetypes::{
    ContainerBlueprint, PanelBlueprint, PlotLegend, TimeAxis, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint,
};
use crate::sdk::types::blueprint::components::{
    ActiveTab, ColumnShare, ContainerKind, Corner2D, IncludedContent, LinkAxis, PanelState,
    QueryExpression, RootContainer, RowShare, ViewClass,
};
use crate::sdk::types::components::{Name, Visible};
use crate::sdk::types::datatypes::TimeRange;
use crate::sdk::{AsComponents, RecordingStream, RecordingStreamBuilder, SerializedComponentBatch};

/// A view's class, as the viewer names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewKind {
    /// Scalars against a timeline.
    TimeSeries,
    /// Markdown or plain text.
    TextDocument,
    /// Nodes and edges.
    Graph,
    /// Bars over an abscissa, on any timeline (static data).
    BarChart,
}

impl ViewKind {
    fn class(self) -> &'static str {
        match self {
            ViewKind::TimeSeries => "TimeSeries",
            ViewKind::TextDocument => "TextDocument",
            ViewKind::Graph => "Graph",
            ViewKind::BarChart => "BarChart",
        }
    }
}

/// One view: a class, a title, the entities it shows, and its properties.
pub struct View {
    /// The view's class.
    pub kind: ViewKind,
    /// Its title.
    pub name: String,
    /// The entity its contents are relative to.
    pub origin: String,
    /// Its properties, by archetype name (`TimeAxis`, `PlotLegend`, ...).
    pub properties: Vec<(&'static str, Vec<SerializedComponentBatch>)>,
}

impl View {
    /// A view of `origin` and everything under it.
    pub fn new(kind: ViewKind, name: impl Into<String>, origin: impl Into<String>) -> View {
        View {
            kind,
            name: name.into(),
            origin: origin.into(),
            properties: Vec::new(),
        }
    }

    /// A time-series view of the whole recording: its time axis shows every instant
    /// (rerun's own default for a run longer than a minute is the cursor ± 30 s), and it
    /// follows its own zoom rather than the other plots'. The legend sits in the lower
    /// right: a heat run's temperatures rise from the lower left, where rerun's default
    /// legend would hide the start of the run.
    pub fn time_series(name: impl Into<String>, origin: impl Into<String>) -> View {
        View::new(ViewKind::TimeSeries, name, origin)
            .with_property(
                "TimeAxis",
                &TimeAxis::new()
                    .with_link(LinkAxis::Independent)
                    .with_view_range(TimeRange::EVERYTHING),
            )
            .with_property(
                "PlotLegend",
                &PlotLegend::new().with_corner(Corner2D::RightBottom),
            )
    }

    /// Adds a property archetype, logged at `view/<id>/<name>`.
    pub fn with_property(mut self, name: &'static str, archetype: &dyn AsComponents) -> View {
        self.properties
            .push((name, archetype.as_serialized_batches()));
        self
    }

    /// Whether this view shows the whole time range (has a `TimeAxis` property).
    pub fn shows_whole_range(&self) -> bool {
        self.properties.iter().any(|(name, _)| *name == "TimeAxis")
    }
}

/// A container or a view.
pub enum Node {
    /// Children side by side, stacked, or in tabs.
    Container {
        /// How the children are arranged.
        kind: ContainerKind,
        /// The title (a tab's label).
        name: String,
        /// The children, in order.
        children: Vec<Node>,
        /// Relative sizes of the children (columns or rows), if not equal.
        shares: Option<Vec<f32>>,
        /// The child shown first, where the container holds tabs (else the first).
        active: Option<usize>,
    },
    /// A view.
    View(View),
}

impl Node {
    /// Children left to right.
    pub fn horizontal(name: impl Into<String>, children: Vec<Node>) -> Node {
        Node::container(ContainerKind::Horizontal, name, children)
    }

    /// Children top to bottom.
    pub fn vertical(name: impl Into<String>, children: Vec<Node>) -> Node {
        Node::container(ContainerKind::Vertical, name, children)
    }

    /// Children as tabs, the first one shown.
    pub fn tabs(name: impl Into<String>, children: Vec<Node>) -> Node {
        Node::container(ContainerKind::Tabs, name, children)
    }

    fn container(kind: ContainerKind, name: impl Into<String>, children: Vec<Node>) -> Node {
        Node::Container {
            kind,
            name: name.into(),
            children,
            shares: None,
            active: None,
        }
    }

    /// Shows the child at `index` first (a tab container's open tab).
    pub fn with_active(mut self, index: usize) -> Node {
        if let Node::Container { active, .. } = &mut self {
            *active = Some(index);
        }
        self
    }

    /// The title: a view's name, or a container's (a tab's label).
    pub fn title(&self) -> &str {
        match self {
            Node::View(v) => &v.name,
            Node::Container { name, .. } => name,
        }
    }

    /// Sets the children's relative sizes (a container's columns or rows).
    pub fn with_shares(mut self, new: impl Into<Vec<f32>>) -> Node {
        if let Node::Container { shares, .. } = &mut self {
            *shares = Some(new.into());
        }
        self
    }

    /// Every view in the tree, depth first.
    pub fn views(&self) -> Vec<&View> {
        match self {
            Node::View(v) => vec![v],
            Node::Container { children, .. } => children.iter().flat_map(Node::views).collect(),
        }
    }
}

impl From<View> for Node {
    fn from(v: View) -> Node {
        Node::View(v)
    }
}

/// A whole viewer layout: the root container, and the side panels collapsed so the
/// plots get the screen.
pub struct Layout {
    /// The root container.
    pub root: Node,
}

/// Ids of containers and views: valid UUIDs (version 4 layout), numbered in logging
/// order, so a replay's blueprint is the same every time.
struct Ids(u64);

impl Ids {
    fn next(&mut self) -> [u8; 16] {
        self.0 += 1;
        let mut b = [0u8; 16];
        b[..4].copy_from_slice(b"heat");
        b[8..].copy_from_slice(&self.0.to_be_bytes());
        b[6] = 0x40; // version 4
        b[8] = 0x80 | (b[8] & 0x3f); // RFC 4122 variant
        b
    }
}

/// The hyphenated lowercase form of a UUID, as entity paths name it.
fn hyphenated(b: &[u8; 16]) -> String {
    let hex: String = b.iter().map(|x| format!("{x:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}

impl Layout {
    /// Logs the layout into a new blueprint store and sends it with `rec`, active and the
    /// default (so "reset blueprint" in the viewer comes back to it).
    pub fn send(&self, rec: &RecordingStream) -> crate::sdk::RecordingStreamResult<()> {
        let application_id = rec
            .store_info()
            .map(|info| info.application_id().clone())
            .unwrap_or_else(|| "heatrun".into());
        let (blueprint, storage) = RecordingStreamBuilder::new(application_id)
            .recording_id(RecordingId::random())
            .blueprint()
            .memory()?;
        // The viewer reads blueprints on this timeline.
        blueprint.set_time_sequence("blueprint", 0);
        let mut ids = Ids(0);
        let root = log_node(&blueprint, &self.root, &mut ids)?;
        blueprint.log(
            "viewport",
            &ViewportBlueprint::new()
                .with_root_container(RootContainer(root.into()))
                .with_auto_layout(false)
                .with_auto_views(false),
        )?;
        for panel in ["blueprint_panel", "selection_panel"] {
            blueprint.log(
                panel,
                &PanelBlueprint::new().with_state(PanelState::Collapsed),
            )?;
        }
        blueprint.log(
            "time_panel",
            &TimePanelBlueprint::new().with_state(PanelState::Collapsed),
        )?;
        let msgs: Vec<LogMsg> = storage.take();
        let Some(id) = msgs.first().map(|m| m.store_id().clone()) else {
            return Ok(());
        };
        rec.send_blueprint(
            msgs,
            BlueprintActivationCommand {
                blueprint_id: id,
                make_active: true,
                make_default: true,
            },
        );
        Ok(())
    }
}

/// Logs a node and its children; returns its id.
fn log_node(
    stream: &RecordingStream,
    node: &Node,
    ids: &mut Ids,
) -> crate::sdk::RecordingStreamResult<[u8; 16]> {
    let id = ids.next();
    match node {
        Node::View(view) => log_view(stream, view, &format!("view/{}", hyphenated(&id)))?,
        Node::Container {
            kind,
            name,
            children,
            shares,
            active,
        } => {
            let mut contents = Vec::with_capacity(children.len());
            for child in children {
                let child_id = log_node(stream, child, ids)?;
                let prefix = match child {
                    Node::View(_) => "view",
                    Node::Container { .. } => "container",
                };
                contents.push(IncludedContent::from(
                    format!("{prefix}/{}", hyphenated(&child_id)).as_str(),
                ));
            }
            let open = active
                .filter(|_| *kind == ContainerKind::Tabs)
                .and_then(|i| contents.get(i))
                .map(|tab| ActiveTab::from(tab.0.clone()));
            let mut arch = ContainerBlueprint::new(*kind)
                .with_display_name(Name::from(name.as_str()))
                .with_contents(contents)
                .with_visible(Visible::from(true));
            if let Some(tab) = open {
                arch = arch.with_active_tab(tab);
            }
            if let Some(shares) = shares {
                arch = match kind {
                    ContainerKind::Vertical => {
                        arch.with_row_shares(shares.iter().map(|&s| RowShare::from(s)))
                    }
                    _ => arch.with_col_shares(shares.iter().map(|&s| ColumnShare::from(s))),
                };
            }
            stream.log(format!("container/{}", hyphenated(&id)), &arch)?;
        }
    }
    Ok(id)
}

/// Logs a view: its contents query, its blueprint and its properties.
fn log_view(
    stream: &RecordingStream,
    view: &View,
    path: &str,
) -> crate::sdk::RecordingStreamResult<()> {
    stream.log(
        format!("{path}/ViewContents"),
        &ViewContents::new([QueryExpression::from("$origin/**")]),
    )?;
    stream.log(
        path,
        &ViewBlueprint::new(ViewClass::from(view.kind.class()))
            .with_display_name(Name::from(view.name.as_str()))
            .with_space_origin(view.origin.as_str()),
    )?;
    for (name, batches) in &view.properties {
        stream.log_serialized_batches(format!("{path}/{name}"), false, batches.iter().cloned())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_distinct_uuids_in_their_hyphenated_form() {
        let mut ids = Ids(0);
        let a = hyphenated(&ids.next());
        let b = hyphenated(&ids.next());
        assert_ne!(a, b);
        for id in [&a, &b] {
            let groups: Vec<usize> = id.split('-').map(str::len).collect();
            assert_eq!(groups, [8, 4, 4, 4, 12], "{id}");
            assert_eq!(&id[14..15], "4", "version 4: {id}");
            assert!("89ab".contains(&id[19..20]), "RFC 4122 variant: {id}");
        }
        assert_eq!(a, "68656174-0000-4000-8000-000000000001");
    }

    #[test]
    fn time_series_views_show_the_whole_recording() {
        let v = View::time_series("t", "temperature");
        assert!(v.shows_whole_range());
        let (name, batches) = &v.properties[0];
        assert_eq!(*name, "TimeAxis");
        let components: Vec<String> = batches
            .iter()
            .map(|b| b.descriptor.component.to_string())
            .collect();
        assert!(
            components.contains(&"TimeAxis:view_range".to_owned()),
            "{components:?}"
        );
        assert!(!View::new(ViewKind::TextDocument, "s", "summary").shows_whole_range());
    }

    #[test]
    fn views_are_listed_depth_first() {
        let tree = Node::tabs(
            "root",
            vec![
                Node::vertical("a", vec![View::time_series("1", "x").into()]),
                View::new(ViewKind::Graph, "2", "y").into(),
            ],
        );
        let names: Vec<&str> = tree.views().iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["1", "2"]);
    }
}
