//! Paint on the screen: the targets drawn in their painted colour, or one painted
//! scalar as a heat map ([`sculpt_core::paint::PaintShading`]).
//!
//! [`PaintView::sync`] hands the document's current fields to the mesh sinks as a
//! [`Tint`](sculpt_core::mesh::Tint) whenever the paint history or the heat-map switch
//! changed (and only then: the renderer samples a new tint into a 3D texture). The
//! renderer blends the tint over the material's albedo per fragment, before lighting
//! ([`crate::render::paint_texture`], `fs_mesh` in `shaders.wgsl`).
//!
//! The heat map shows the first scalar painted (not `colour`, e.g. `density`): the
//! `T` key in the desktop window, `--heat-map` (or `[display] heat_map = true`) for
//! every run, headless included. The HUD says which scalar it shows.
//!
//! ```
//! use sculpt_core::editor::default_document;
//! use vr_app::paint_view::PaintView;
//! let mut view = PaintView::default();
//! view.toggle_heat();
//! assert!(view.heat());
//! assert_eq!(view.hud_line(&default_document()).as_deref(), Some("heat map: nothing painted but colour"));
//! ```

use sculpt_core::mesh::MeshSink;
use sculpt_core::paint::PaintShading;
use sculpt_core::sculpt::document::Document;

/// What a sink was last tinted with: the heat map's scalar (`None`: colour) and the
/// paint steps' ids.
type Shown = (Option<String>, Vec<u64>);

/// The paint shading of one set of sinks: whether the heat map is on, and what the
/// sinks were last given.
#[derive(Debug, Default)]
pub struct PaintView {
    heat: bool,
    shown: Option<Shown>,
}

impl PaintView {
    /// Whether the heat map is on.
    pub fn heat(&self) -> bool {
        self.heat
    }

    /// Turns the heat map on or off.
    pub fn set_heat(&mut self, on: bool) {
        self.heat = on;
    }

    /// Turns the heat map on if off, off if on.
    pub fn toggle_heat(&mut self) {
        self.heat = !self.heat;
    }

    /// The scalar the heat map shows in `doc`: the first one painted, when the heat
    /// map is on.
    pub fn heat_attribute<'a>(&self, doc: &'a Document) -> Option<&'a str> {
        self.heat.then(|| doc.first_scalar()).flatten()
    }

    /// Tints `sinks` with `doc`'s paint (the colour, or the heat map) when it changed
    /// since the last call; `None` clears a tint when nothing is painted any more.
    pub fn sync(&mut self, doc: &Document, sinks: [&mut dyn MeshSink; 2]) {
        let attribute = self.heat_attribute(doc).map(str::to_owned);
        let shown = (
            attribute.clone(),
            doc.paints().iter().map(|p| p.id).collect(),
        );
        if self.shown.as_ref() == Some(&shown) {
            return;
        }
        let tint = doc
            .paint_shading(attribute.as_deref())
            .map(PaintShading::into_tint);
        for sink in sinks {
            sink.set_tint(tint.clone());
        }
        self.shown = Some(shown);
    }

    /// The HUD's line while the heat map is on: the scalar it shows.
    pub fn hud_line(&self, doc: &Document) -> Option<String> {
        self.heat.then(|| match doc.first_scalar() {
            Some(name) => format!("heat map: {name}"),
            None => "heat map: nothing painted but colour".to_owned(),
        })
    }
}
