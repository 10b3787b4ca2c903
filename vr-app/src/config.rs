//! The `wandsculpt` configuration file (TOML).
//!
//! Every section is optional; a missing section takes its defaults, which describe a
//! desktop: one 0.6 m x 0.34 m monitor, mono output, no tracker (desktop mode with the
//! emulated wand). Unknown keys are errors, so a typo never silently does nothing.
//! Two documented examples ship in `vr-app/config/`: `wall.toml` (a two-projector
//! passive-stereo wall with an ART tracker) and `desktop.toml`.
//!
//! ```
//! let cfg = vr_app::config::Config::from_toml_str(r#"
//!     [display]
//!     mode = "side-by-side"
//!     [screen]
//!     lower_left = [-1.5, 0.0, 0.0]
//!     lower_right = [1.5, 0.0, 0.0]
//!     upper_left = [-1.5, 2.2, 0.0]
//!     [tracking]
//!     wand = "wand1"
//!     head = "body0"
//!     [[tracking.input.source]]
//!     kind = "tcp-listen"
//!     addr = "127.0.0.1:5001"
//! "#)?;
//! assert_eq!(cfg.display.mode, vr_app::render::OutputMode::SideBySide);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use std::path::{Path, PathBuf};

use glam::DVec3;
use sculpt_core::interaction::{InteractionConfig, InteractionMode, Profile, StrokeMode, Tool};
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, VrError, VrResult};
use crate::output::OutputMode;
use crate::projection::{HeadPose, StereoRig};

pub mod cluster;
mod screen;

pub use screen::ScreenConfig;

/// The whole configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Outputs and windows.
    pub display: DisplayConfig,
    /// Picture: material and anti-aliasing.
    pub render: RenderConfig,
    /// The physical screen.
    pub screen: ScreenConfig,
    /// Eye separation and clip planes.
    pub stereo: StereoRig,
    /// The head position used without a head tracker.
    pub head: HeadConfig,
    /// Where tracking comes from; absent means desktop mode.
    pub tracking: Option<TrackingSection>,
    /// Starting tool and mode.
    pub tool: ToolConfig,
    /// State machine tuning and button map.
    pub interaction: InteractionConfig,
    /// Journal, autosave and output files.
    pub files: FilesConfig,
    /// The CAVE cluster / shared sculpting over NATS (`wandsculpt --cluster`).
    pub cluster: Option<cluster::ClusterSection>,
}

/// Output settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DisplayConfig {
    /// `dual`, `side-by-side`, `anaglyph` or `mono`.
    pub mode: OutputMode,
    /// Swap the eyes (projectors or filters wired the other way round).
    pub swap_eyes: bool,
    /// Monitor indices (as winit lists them) for the outputs: `[left, right]` in dual
    /// mode, the first entry otherwise.
    pub monitors: Vec<usize>,
    /// Fullscreen on the chosen monitors.
    pub fullscreen: bool,
    /// Window or offscreen size per output, pixels.
    pub width: u32,
    /// Height per output, pixels.
    pub height: u32,
    /// Draw the mesh wireframe.
    pub wireframe: bool,
    /// Draw the UV quadtree leaves, coloured by class (`G` toggles it).
    pub quadtree: bool,
    /// Show the first painted scalar (e.g. `density`) as a heat map instead of the
    /// painted colour (`T` toggles it; [`crate::paint_view`]).
    pub heat_map: bool,
    /// Show the HUD.
    pub hud: bool,
}

impl Default for DisplayConfig {
    fn default() -> Self {
        Self {
            mode: OutputMode::Mono,
            swap_eyes: false,
            monitors: Vec::new(),
            fullscreen: false,
            width: 1280,
            height: 720,
            wireframe: false,
            quadtree: false,
            heat_map: false,
            hud: true,
        }
    }
}

/// Picture settings (`[render]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Surface material: `clay`, `stone` or `wood` (the `M` key steps through them).
    pub material: crate::render::material::Material,
    /// Samples per pixel wanted: 1 (off), 2 or 4; the adapter may allow fewer.
    pub msaa: u32,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            material: Default::default(),
            msaa: 4,
        }
    }
}

/// The fixed head, used when no head tracker is configured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct HeadConfig {
    /// Head position (metres, display frame); by default 0.6 m in front of the
    /// screen centre.
    pub position: Option<[f64; 3]>,
}

/// Tracking: which devices are the wand and the head, and the tracking crate's own
/// input configuration (sources, filter, calibration, loss timeout) under
/// `[tracking.input]`, as documented in `docs/formats/tracking-config.md`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingSection {
    /// The wand device: `wandN` (a Flystick; the frame stage reads Flysticks only).
    pub wand: String,
    /// The head (glasses) device, usually `bodyN`; absent means a fixed head.
    #[serde(default)]
    pub head: Option<String>,
    /// Seconds without a wand report before the wand counts as lost (the frame
    /// stage's timeout; default 0.5, as in `replay`).
    #[serde(default = "stage_timeout_default")]
    pub timeout: f64,
    /// Sources, filter, calibration.
    #[serde(default)]
    pub input: tracking::config::TrackingConfig,
    /// A source the app plays itself: a pose-log file or the simulator.
    #[serde(default)]
    pub playback: Option<Playback>,
    /// The wand's analog axes as tool changes (`[tracking.thumbstick]`, as `replay`'s
    /// `[thumbstick]`); absent: the axes change nothing.
    #[serde(default)]
    pub thumbstick: Option<crate::thumbstick::ThumbstickTool>,
}

/// A source the app plays into the hub itself, in real time: `[tracking.playback]`
/// (played by the `live` module, which also reads its frames).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Playback {
    /// A recorded pose log (`.poselog`), its DTrack frames sent with their recorded
    /// timing.
    Poselog {
        /// The log file.
        path: PathBuf,
        /// Playback speed (1 = as recorded; 2 = twice as fast).
        #[serde(default = "speed_default")]
        speed: f64,
    },
    /// The tracker simulator (`tracking::sim`) playing a script.
    Sim {
        /// A script file (TOML, the `tracksim` format); absent: the built-in script, a
        /// carve stroke across the default surface.
        #[serde(default)]
        script: Option<PathBuf>,
        /// Simulator settings (rate, seed, noise, ids).
        #[serde(default)]
        config: tracking::sim::SimConfig,
        /// Playback speed (1 = real time).
        #[serde(default = "speed_default")]
        speed: f64,
    },
}

fn speed_default() -> f64 {
    1.0
}

impl Playback {
    /// A short description (`poselog FILE`, `sim`).
    pub fn describe(&self) -> String {
        match self {
            Playback::Poselog { path, .. } => format!("poselog {}", path.display()),
            Playback::Sim {
                script: Some(p), ..
            } => format!("sim {}", p.display()),
            Playback::Sim { script: None, .. } => "sim (built-in script)".into(),
        }
    }

    /// Checks the speed.
    pub fn validate(&self) -> VrResult<()> {
        let speed = match self {
            Playback::Poselog { speed, .. } | Playback::Sim { speed, .. } => *speed,
        };
        if !(speed.is_finite() && speed > 0.0 && speed <= 1000.0) {
            return Err(VrError::Config(ConfigError::PlaybackSpeed(speed)));
        }
        Ok(())
    }

    /// The playback speed (1 = as recorded).
    pub fn speed(&self) -> f64 {
        match self {
            Playback::Poselog { speed, .. } | Playback::Sim { speed, .. } => *speed,
        }
    }
}

/// A `[tracking]` setting the tracking layer refused.
fn tracking_config(field: &'static str, cause: tracking::TrackingError) -> VrError {
    VrError::Config(ConfigError::Tracking {
        field,
        cause: Box::new(cause),
    })
}

fn stage_timeout_default() -> f64 {
    tracking::stage::StageConfig::default().timeout_s
}

impl TrackingSection {
    /// The wand's device id.
    pub fn wand_id(&self) -> VrResult<tracking::DeviceId> {
        self.wand
            .parse()
            .map_err(|cause| tracking_config("tracking.wand", cause))
    }

    /// The frame stage's config: the wand's Flystick id, the head's body id, the
    /// timeout, and the calibration and filter of `[tracking.input]`. The stage needs
    /// the wand to be a Flystick (`wandN`).
    pub fn stage_config(&self) -> VrResult<tracking::stage::StageConfig> {
        let wand_id = match self.wand_id()? {
            tracking::DeviceId::Wand(id) => id,
            other => {
                return Err(VrError::Config(ConfigError::WandNotFlystick(other)));
            }
        };
        let head_id = match self.head_id()? {
            None => None,
            Some(tracking::DeviceId::Body(id)) => Some(id),
            Some(other) => {
                return Err(VrError::Config(ConfigError::HeadNotBody(other)));
            }
        };
        let stage = tracking::stage::StageConfig {
            wand_id,
            head_id,
            timeout_s: self.timeout,
            calibration: self.input.calibration.clone(),
            filter: self.input.filter,
        };
        stage
            .validate()
            .map_err(|cause| tracking_config("tracking", cause))?;
        if let Some(stick) = &self.thumbstick {
            stick
                .validate()
                .map_err(|e| VrError::Config(ConfigError::Thumbstick(e)))?;
        }
        Ok(stage)
    }

    /// The head's device id, if configured.
    pub fn head_id(&self) -> VrResult<Option<tracking::DeviceId>> {
        self.head
            .as_deref()
            .map(|h| {
                h.parse()
                    .map_err(|cause| tracking_config("tracking.head", cause))
            })
            .transpose()
    }
}

/// Starting tool and mode (the `[tool]` table); what is left out is
/// [`Tool::default`]'s, in carve mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ToolConfig {
    /// Starting mode: `sketch`, `carve` or `emboss`.
    pub mode: InteractionMode,
    /// Profile: `v`, `u` or `{ custom = [[x, f], ...] }`.
    pub profile: Profile,
    /// Width (metres).
    pub width: f64,
    /// Depth (metres).
    pub depth: f64,
    /// End taper length (metres).
    pub taper: f64,
}

impl Default for ToolConfig {
    fn default() -> Self {
        let t = Tool::default();
        Self {
            mode: InteractionMode::Stroke(t.mode),
            profile: t.profile,
            width: t.width,
            depth: t.depth,
            taper: t.taper,
        }
    }
}

impl ToolConfig {
    /// The tool; starting in sketch mode, it carves once the mode button leaves
    /// sketching.
    pub fn tool(&self) -> Tool {
        Tool {
            profile: self.profile.clone(),
            width: self.width,
            depth: self.depth,
            mode: self.mode.stroke_mode().unwrap_or(StrokeMode::Carve),
            taper: self.taper,
        }
    }
}

/// Output files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilesConfig {
    /// Directory for the journal, autosave, documents and screenshots.
    pub dir: PathBuf,
    /// Autosave the document after this many operations (0 = never).
    pub autosave_every: u32,
    /// The base scene the session starts from (a `Document::to_json` file, like a
    /// saved `scene.json`); absent means the shared default surface.
    pub scene: Option<PathBuf>,
    /// A solid target added to the base scene (`--solid`): a JSON solid document or a
    /// `.vm` model file ([`crate::solid_view::load_solid`]); absent means none.
    pub solid: Option<PathBuf>,
    /// Grid cells along the solid's longest side (`--solid-cells`; default
    /// [`sculpt_core::solid::DEFAULT_CELLS`], in [`sculpt_core::solid::CELLS_RANGE`]).
    pub solid_cells: usize,
}

impl Default for FilesConfig {
    fn default() -> Self {
        Self {
            dir: PathBuf::from("wandsculpt-session"),
            autosave_every: 5,
            scene: None,
            solid: None,
            solid_cells: sculpt_core::solid::DEFAULT_CELLS,
        }
    }
}

impl Config {
    /// Parses and validates a TOML string.
    pub fn from_toml_str(text: &str) -> VrResult<Self> {
        let cfg: Config =
            toml::from_str(text).map_err(|e| VrError::Config(ConfigError::Toml(Box::new(e))))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Reads and validates a TOML file.
    pub fn load(path: impl AsRef<Path>) -> VrResult<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| VrError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text).map_err(|e| VrError::ConfigFile {
            path: path.to_path_buf(),
            reason: Box::new(e),
        })
    }

    /// Checks values the types cannot.
    pub fn validate(&self) -> VrResult<()> {
        let screen = self.screen.screen()?;
        let s = &self.stereo;
        if !(s.ipd.is_finite() && (0.0..=0.2).contains(&s.ipd)) {
            return Err(VrError::Config(ConfigError::Ipd(s.ipd)));
        }
        if !(s.near > 0.0 && s.far > s.near && s.far.is_finite()) {
            return Err(VrError::Config(ConfigError::ClipPlanes));
        }
        let d = &self.display;
        if !(1..=16384).contains(&d.width) || !(1..=16384).contains(&d.height) {
            return Err(VrError::Config(ConfigError::DisplaySize {
                width: d.width,
                height: d.height,
            }));
        }
        if ![1, 2, 4].contains(&self.render.msaa) {
            return Err(VrError::Config(ConfigError::Msaa(self.render.msaa)));
        }
        self.tool.tool().validate()?;
        // The same check as replay's (sculpt-core's, one for both).
        self.interaction
            .validate()
            .map_err(|e| VrError::Config(ConfigError::Interaction(e)))?;
        if let Some(p) = self.head.position {
            let p = DVec3::from(p);
            let (_, _, vn) = screen.basis();
            if !p.is_finite() || (p - screen.lower_left).dot(vn) <= 0.0 {
                return Err(VrError::Config(ConfigError::HeadPosition));
            }
        }
        if let Some(c) = &self.cluster {
            c.validate()?;
            for n in &c.nodes {
                if let Some(s) = &n.screen {
                    s.screen()?;
                }
            }
        }
        if let Some(t) = &self.tracking {
            t.stage_config()?;
            t.input
                .validate()
                .map_err(|cause| tracking_config("tracking.input", cause))?;
            if let Some(p) = &t.playback {
                p.validate()?;
            }
            if t.input.sources.is_empty() && t.playback.is_none() {
                return Err(VrError::Config(ConfigError::NoTrackingSource));
            }
        }
        Ok(())
    }

    /// The fixed head pose (configured, or 0.6 m in front of the screen centre).
    pub fn fixed_head(&self) -> VrResult<HeadPose> {
        let screen = self.screen.screen()?;
        let mut head = crate::projection::fixed_head(&screen, 0.6);
        if let Some(p) = self.head.position {
            head.position = p.into();
        }
        Ok(head)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::tolerance::EXACT_EPS;

    fn example(name: &str) -> Config {
        Config::load(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("config")
                .join(name),
        )
        .unwrap()
    }

    #[test]
    fn shipped_examples_parse() {
        let wall = example("wall.toml");
        assert_eq!(wall.display.mode, OutputMode::Dual);
        assert_eq!(wall.display.monitors, vec![1, 2]);
        let t = wall.tracking.as_ref().unwrap();
        assert_eq!(t.head_id().unwrap(), Some(tracking::DeviceId::Body(0)));
        assert_eq!(t.wand_id().unwrap(), tracking::DeviceId::Wand(1));
        assert!(matches!(
            t.input.sources[0],
            tracking::config::SourceConfig::TcpListen { .. }
        ));
        let desk = example("desktop.toml");
        assert!(desk.tracking.is_none());
        assert_eq!(desk.display.mode, OutputMode::Mono);
        assert_eq!(
            desk.render.material,
            crate::render::material::Material::Clay
        );
        let stone = Config::from_toml_str("[render]\nmaterial = \"stone\"\nmsaa = 1").unwrap();
        assert_eq!(
            stone.render.material,
            crate::render::material::Material::Stone
        );
        assert_eq!(stone.render.msaa, 1);
    }

    #[test]
    fn empty_file_is_the_desktop_default() {
        let c = Config::from_toml_str("").unwrap();
        assert_eq!(c, Config::default());
        let head = c.fixed_head().unwrap();
        sculpt_core::assert_near!(head.position.to_array(), [0.0, 1.17, 0.6], EXACT_EPS);
    }

    #[test]
    fn the_quadtree_overlay_is_a_display_key() {
        assert!(!Config::default().display.quadtree);
        let c = Config::from_toml_str("[display]\nquadtree = true").unwrap();
        assert!(c.display.quadtree);
    }

    #[test]
    fn bad_configs_are_clear_errors() {
        for (text, needle) in [
            ("[display]\nmode = \"holo\"", "unknown variant"),
            ("[display]\nbogus = 1", "unknown field"),
            (
                "[screen]\nlower_left = [0,0,0]\nlower_right = [0,0,0]\nupper_left = [0,1,0]",
                "edge",
            ),
            ("[stereo]\nipd = -1.0", "ipd"),
            ("[tool]\nwidth = 0.0", "width"),
            ("[head]\nposition = [0.0, 1.0, -2.0]", "in front"),
            ("[tracking]\nwand = \"stick1\"", "tracking.wand"),
            ("[tracking]\nwand = \"wand1\"", "at least one"),
            (
                "[tracking]\nwand = \"body1\"\n[tracking.playback]\nkind = \"sim\"",
                "Flystick",
            ),
            (
                "[tracking]\nwand = \"wand1\"\n[tracking.playback]\nkind = \"sim\"\nspeed = 0.0",
                "speed",
            ),
            ("[display]\nwidth = 0", "size"),
            ("[render]\nmaterial = \"marble\"", "unknown variant"),
            ("[render]\nmsaa = 3", "render.msaa"),
        ] {
            let e = Config::from_toml_str(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?} gave {e:?}");
        }
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(128))]
            #[test]
            fn arbitrary_text_never_panics(text in "[\\[\\]a-z_=. 0-9\"\n{},-]{0,200}") {
                let _ = Config::from_toml_str(&text);
            }
        }
    }
}
