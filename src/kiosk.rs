//! The kiosk's state, free of windows, cameras and GPUs: its configuration (a TOML file), the
//! visitor's controls, the orbit camera driven by drags, pinches and the wheel, and the ease
//! back to the default portrait when nobody is there.
//!
//! Units: angles in degrees, times in seconds, drags in logical window pixels, face positions
//! in model millimetres (`[x0, y0, z0, x1, ...]`).
//!
//! Length: 530 lines of code, then its unit tests (197 lines), kept beside what they test.

use std::path::{Path, PathBuf};

use crate::gem::{CameoParams, Setting, View};
use crate::render::{Material, RenderParams, ZOOM_RANGE};
use crate::sss::SssParams;
use crate::styles::Style;

pub mod visitor;
pub use visitor::Labels;
pub use visitor::{
    ATTRACT, Attract, Change, HoldGesture, Mode, PIN_MAX_PAUSE_S, PIN_PAUSE_S, PIN_TRIES, PinGate,
    PinOutcome, Presence, Prompt, STAFF_HOLD_S, Situation, StaffAction, Texts, prompt,
    staff_action,
};

/// The window width (logical pixels) the controls are laid out for: the default window.
pub const CONTROLS_WIDTH: f32 = 800.0;

/// How much the controls are scaled in a window `width_px` physical pixels wide whose
/// display scale is `scale_factor`: wider than [`CONTROLS_WIDTH`] they grow with it (a
/// 1024-pixel kiosk screen gets finger-sized buttons across its width, not a windowed
/// layout in its lower left; issue #41), never smaller than designed, at most 3x.
pub fn controls_zoom(width_px: u32, scale_factor: f64) -> f32 {
    let logical = width_px as f32 / scale_factor.max(0.1) as f32;
    (logical / CONTROLS_WIDTH).clamp(1.0, 3.0)
}

/// The SSS strength the reset button returns to (red's, as `glyptic render --sss-strength`).
pub const DEFAULT_SSS_STRENGTH: f32 = crate::sss::DEFAULT_STRENGTH;
/// Degrees of orbit per pixel dragged.
pub const DEGREES_PER_PIXEL: f32 = 0.35;
/// How far the camera may orbit: beyond these the stone's edge or back fills the view.
pub const MAX_YAW_DEG: f32 = 70.0;
pub const MAX_PITCH_DEG: f32 = 60.0;

/// Why a configuration file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{path}: cannot read: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// TOML syntax, an unknown key or a value of the wrong type (the message names the line).
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: `{key}` {problem}")]
    Invalid {
        path: PathBuf,
        key: &'static str,
        problem: String,
    },
}

/// Kiosk defaults, read from a TOML file; every key is optional. Command-line options override
/// the file.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KioskConfig {
    /// Webcam index (/dev/videoN); ignored when `video` is set.
    pub camera: u32,
    /// Play this video file (looping), or show this photo as if a camera saw it, instead of
    /// a camera.
    pub video: Option<PathBuf>,
    pub material: Material,
    pub portrait: View,
    /// The gold round the stone (`plain`, `milgrain`, `rope`).
    pub setting: Setting,
    /// A ring on the setting's top, as a pendant has.
    pub bail: bool,
    /// Subsurface scattering on at start.
    pub sss: bool,
    /// SSS strength at start, 0..=1.
    pub sss_strength: f32,
    /// Seconds without a face before the portrait eases back to the default face.
    pub idle_seconds: f32,
    /// Seconds the ease back takes.
    pub ease_seconds: f32,
    /// Fill the screen: the monitor's size at its origin (so no window manager is needed),
    /// without decorations.
    pub fullscreen: bool,
    /// Hide the mouse cursor (a touch screen's visitors have no use for it); unset: hidden
    /// when full screen.
    pub hide_cursor: Option<bool>,
    /// The attract mode: when nobody has been seen for `attract_seconds`, the default gem
    /// turns slowly under a caption inviting the next visitor.
    pub attract: bool,
    /// Seconds without a face or a touch before the attract mode (never before the visitor
    /// has left, after `idle_seconds`).
    pub attract_seconds: f32,
    /// A finger held on the screen's top-left corner for four seconds asks for the staff's
    /// PIN (`staff_pin`), then opens the staff panel; without a PIN it opens nothing.
    pub staff_gesture: bool,
    /// The staff's PIN as `glyptic kiosk --hash-pin` prints it (a salted hash, never the
    /// PIN). Set, every way to the staff panel and to Quit asks for it (the corner, the
    /// keys); unset, only the keys open the panel. A few wrong PINs pause the pad.
    pub staff_pin: Option<String>,
    /// The most pictures the Save button keeps in the snapshots folder, and the most
    /// megabytes they take; past either, Save says the gallery is full and the staff panel
    /// lists it (nothing is deleted).
    pub snapshots_max: u32,
    pub snapshots_max_mb: u32,
    /// The visitor's words ([`visitor::Texts`]): another language, the museum's voice.
    pub texts: visitor::Texts,
    /// The controls' labels ([`visitor::Labels`]), for the same reasons.
    pub labels: visitor::Labels,
    /// The engraved border on the ground at start.
    pub engraving: bool,
    /// The raking lamp and its shadows at start.
    pub lamp: bool,
    /// Agate: the hair cut from a third, brown layer.
    pub hair_layer: bool,
    /// The visitor's own hair, beard and moustache, read from the camera (off: the classical
    /// hair for everyone).
    pub visitor_hair: bool,
    /// With `visitor_hair`: glasses found on the visitor are carved (off: left out).
    pub glasses: bool,
    /// Faces the likeness search draws for each visitor, once their identity holds (the
    /// portrait's identity steered towards their face by the recognition network, on the
    /// person thread: about half a second of one core for 22), then the face's shape read from
    /// the same frame's shading ([`crate::photometric`]); 0: the landmark fit's identity and
    /// shape.
    /// Longer searches fit the network's own quirks more than the visitor (BENCHMARKS.md,
    /// issue #37).
    pub likeness_search: u32,
    /// How deep the visitor's darks are stippled into the face, 0..=3 (round pits as a
    /// stipple engraver renders tone; carved with the visitor's detail, read with the likeness
    /// search): 0 leaves the skin smooth, 1 as measured (BENCHMARKS.md, issue #37).
    pub stipple: f32,
    /// How deep the visitor's dark lines are engraved into the face, 0..=3 (the lash line,
    /// the lid's crease, the lips' line, the folds, as grooves; carved with the visitor's
    /// detail): 0 leaves them to the stipple and the slopes, 1 as measured (BENCHMARKS.md,
    /// issue #37, seventeenth session).
    pub engraved_lines: f32,
    /// How much of the visitor's darkest darks is sunk into the key light's shadow, 0..=1
    /// (carved with the visitor's detail): 0 leaves them to the slopes and the stipple, 1 as
    /// measured (BENCHMARKS.md, issue #37, twelfth session).
    pub shadows: f32,
    /// How much of the visitor's face's fine modelling is their photo's light and dark rather
    /// than the fitted shape's, 0..=1 (carved with the visitor's detail): 1 as measured
    /// (BENCHMARKS.md, issue #37, fourteenth session), 0 both added.
    pub photo_modelling: f32,
    /// How the visitor's carved light and dark is matched to their photo's as the stone's
    /// light shows it, 0..=3 (the contrast asked for against the carving's own; carved with
    /// the visitor's detail): 0 not, 1.5 as measured (BENCHMARKS.md, issue #37, sixteenth
    /// session).
    pub tone_match: f32,
    /// Window size when not full-screen, logical pixels.
    pub width: u32,
    pub height: u32,
    /// Fraction of the window's pixels (per side) the gem is rendered at, 0.25..=1: on a CPU
    /// rasteriser a full-screen frame costs about half a second.
    pub render_scale: f32,
}

impl KioskConfig {
    /// The staff's PIN, read from `staff_pin` (`Ok(None)`: none set).
    pub fn staff_pin(&self) -> Result<Option<crate::pin::StaffPin>, crate::pin::PinError> {
        self.staff_pin
            .as_deref()
            .map(crate::pin::StaffPin::parse)
            .transpose()
    }

    /// The cameo the gem thread builds: the portrait's view in this setting.
    pub fn cameo(&self) -> CameoParams {
        CameoParams {
            setting: self.setting,
            bail: self.bail,
            ..self.portrait.cameo()
        }
    }
}

impl Default for KioskConfig {
    fn default() -> Self {
        KioskConfig {
            camera: 0,
            video: None,
            material: Material::Marble,
            portrait: View::Frontal,
            setting: Setting::Plain,
            bail: false,
            sss: true,
            sss_strength: DEFAULT_SSS_STRENGTH,
            idle_seconds: 8.0,
            ease_seconds: 2.0,
            fullscreen: false,
            hide_cursor: None,
            attract: true,
            attract_seconds: 30.0,
            staff_gesture: true,
            staff_pin: None,
            snapshots_max: 1000,
            snapshots_max_mb: 2000,
            texts: visitor::Texts::default(),
            labels: visitor::Labels::default(),
            engraving: false,
            lamp: false,
            hair_layer: true,
            visitor_hair: true,
            glasses: true,
            likeness_search: 22,
            stipple: 1.0,
            engraved_lines: 1.0,
            shadows: 1.0,
            photo_modelling: crate::gem::PHOTO_MODELLING,
            tone_match: crate::gem::TONE_MATCH,
            width: 800,
            height: 1000,
            render_scale: 1.0,
        }
    }
}

impl KioskConfig {
    /// How the visitor's detail is carved: the photo path's, the stipple and the darks'
    /// shadows as configured.
    pub fn detail(&self) -> crate::gem::DetailParams {
        crate::gem::DetailParams::default()
            .stipple_scaled(self.stipple)
            .engraved_lines_scaled(self.engraved_lines)
            .with_shadows(self.shadows)
            .with_photo_modelling(self.photo_modelling)
            .with_tone_match(self.tone_match)
    }

    /// Whether the cursor is hidden: as configured, else when full screen.
    pub fn hides_cursor(&self) -> bool {
        self.hide_cursor.unwrap_or(self.fullscreen)
    }

    /// Reads and checks a configuration file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = crate::files::read_text_limited(path, crate::files::MAX_TEXT_BYTES).map_err(
            |source| ConfigError::Read {
                path: path.to_owned(),
                source,
            },
        )?;
        Self::parse(&text, path)
    }

    /// Parses and checks configuration text (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self, ConfigError> {
        let config: KioskConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: path.to_owned(),
            message: e.to_string().trim_end().replace('\n', " "),
        })?;
        config.check(path)?;
        Ok(config)
    }

    /// Every value within its range (finite numbers, a window that fits a screen).
    pub fn check(&self, path: &Path) -> Result<(), ConfigError> {
        let invalid = |key, problem: String| {
            Err(ConfigError::Invalid {
                path: path.to_owned(),
                key,
                problem,
            })
        };
        let within = |v: f32, lo: f32, hi: f32| v.is_finite() && (lo..=hi).contains(&v);
        for (key, v, lo, hi) in [
            ("sss_strength", self.sss_strength, 0.0, 1.0),
            ("idle_seconds", self.idle_seconds, 0.0, 86_400.0),
            ("ease_seconds", self.ease_seconds, 0.0, 60.0),
            ("render_scale", self.render_scale, 0.25, 1.0),
            ("attract_seconds", self.attract_seconds, 1.0, 86_400.0),
            ("stipple", self.stipple, 0.0, 3.0),
            ("engraved_lines", self.engraved_lines, 0.0, 3.0),
            ("shadows", self.shadows, 0.0, 1.0),
            ("photo_modelling", self.photo_modelling, 0.0, 1.0),
            ("tone_match", self.tone_match, 0.0, 3.0),
        ] {
            if !within(v, lo, hi) {
                return invalid(key, format!("is {v}, not within {lo}..={hi}"));
            }
        }
        if let Some((key, problem)) = self.texts.problem() {
            return Err(ConfigError::Invalid {
                path: path.to_owned(),
                key: "texts",
                problem: format!("{key} {problem}"),
            });
        }
        if let Some((key, problem)) = self.labels.problem() {
            return Err(ConfigError::Invalid {
                path: path.to_owned(),
                key: "labels",
                problem: format!("{key} {problem}"),
            });
        }
        if self.likeness_search > 2000 {
            return invalid(
                "likeness_search",
                format!("is {}, not within 0..=2000 faces", self.likeness_search),
            );
        }
        if let Err(e) = self.staff_pin() {
            return invalid("staff_pin", e.to_string());
        }
        for (key, v, hi) in [
            ("snapshots_max", self.snapshots_max, 1_000_000),
            ("snapshots_max_mb", self.snapshots_max_mb, 10_000_000),
        ] {
            if !(1..=hi).contains(&v) {
                return invalid(key, format!("is {v}, not within 1..={hi}"));
            }
        }
        if self
            .video
            .as_ref()
            .is_some_and(|v| v.as_os_str().is_empty())
        {
            return invalid(
                "video",
                "is empty: name a video or photo file, or leave it out for the camera".into(),
            );
        }
        for (key, v) in [("width", self.width), ("height", self.height)] {
            if !(64..=8192).contains(&v) {
                return invalid(key, format!("is {v}, not within 64..=8192 pixels"));
            }
        }
        Ok(())
    }
}

/// What the visitor has chosen with the controls.
#[derive(Clone, Debug, PartialEq)]
pub struct Controls {
    pub material: Material,
    pub sss: bool,
    /// Red's strength, 0..=1 (green and blue follow in [`crate::sss::CHANNEL_BALANCE`]).
    pub sss_strength: f32,
    /// The portrait stays as it is while frozen (new fits are ignored).
    pub frozen: bool,
    /// A gallery style over the gem.
    pub style: Option<Style>,
    /// The engraved border on the ground.
    pub engraving: bool,
    /// The raking lamp and its shadows.
    pub lamp: bool,
}

/// The longest gem frame, ms, at which a moving style is animated (30 frames a second).
pub const ANIMATION_BUDGET_MS: f64 = 33.0;

/// The styles the kiosk's style button steps through, after none: the GPU passes first,
/// then dithering (on the CPU, after a readback of the gem).
pub const KIOSK_STYLES: [Style; 5] = [
    Style::Toon,
    Style::Painterly,
    Style::FishEye,
    Style::Chromatic,
    Style::Dither,
];

impl Controls {
    pub fn from_config(c: &KioskConfig) -> Self {
        Controls {
            material: c.material,
            sss: c.sss,
            sss_strength: c.sss_strength,
            frozen: false,
            style: None,
            engraving: c.engraving,
            lamp: c.lamp,
        }
    }

    /// The SSS toggle's label: the state it is in now (the 2021 kiosk showed the next state,
    /// which visitors read as the current one).
    pub fn sss_label<'a>(&self, l: &'a Labels) -> &'a str {
        if self.sss { &l.glow_on } else { &l.glow_off }
    }

    pub fn freeze_label<'a>(&self, l: &'a Labels) -> &'a str {
        if self.frozen {
            &l.portrait_frozen
        } else {
            &l.portrait_live
        }
    }

    /// The border button's label: its state now.
    pub fn engraving_label<'a>(&self, l: &'a Labels) -> &'a str {
        if self.engraving {
            &l.border_on
        } else {
            &l.border_off
        }
    }

    /// The lamp button's label: its state now.
    pub fn lamp_label<'a>(&self, l: &'a Labels) -> &'a str {
        if self.lamp { &l.lamp_on } else { &l.lamp_off }
    }

    /// The style button's label: the style shown now.
    pub fn style_label(&self, l: &Labels) -> String {
        format!(
            "{}: {}",
            l.style,
            self.style.map_or(l.style_none.as_str(), |s| s.name())
        )
    }

    /// The next style: none, then each of [`KIOSK_STYLES`], then none again.
    pub fn next_style(&mut self) {
        self.style = match self.style {
            None => Some(KIOSK_STYLES[0]),
            Some(s) => KIOSK_STYLES
                .iter()
                .position(|&k| k == s)
                .and_then(|i| KIOSK_STYLES.get(i + 1).copied()),
        };
    }

    /// Whether the gem is redrawn every frame to animate its style: only for a moving style,
    /// and only when the last gem frame took at most [`ANIMATION_BUDGET_MS`] (a real GPU; on a
    /// CPU rasteriser the style stays still rather than make the controls sluggish).
    pub fn animates(&self, last_gem_ms: f64) -> bool {
        self.style.is_some_and(Style::is_animated) && last_gem_ms <= ANIMATION_BUDGET_MS
    }

    pub fn reset_strength(&mut self) {
        self.sss_strength = DEFAULT_SSS_STRENGTH;
    }

    /// Render parameters for these choices over `base` (size, background, marble).
    pub fn apply(&self, base: &RenderParams, orbit: &Orbit) -> RenderParams {
        let sss = self.sss.then(|| SssParams {
            strength: SssParams::strength_rgb(self.sss_strength.clamp(0.0, 1.0)),
            ..SssParams::default()
        });
        RenderParams {
            material: self.material,
            sss,
            yaw_deg: orbit.yaw_deg,
            pitch_deg: orbit.pitch_deg,
            zoom: orbit.zoom,
            styles: self.style.into_iter().collect(),
            engraving: self
                .engraving
                .then(crate::render::surface::EngravingParams::default),
            lamp: self.lamp.then(crate::render::Lamp::default),
            ..base.clone()
        }
    }
}

/// How the gem is drawn while the visitor turns or zooms it: smaller, from a coarser mesh,
/// without MSAA (the renderer's FXAA pass smooths its outline instead) and with a shorter
/// scattering kernel, so that on a CPU rasteriser it follows the hand (the still frame at full
/// quality follows once the hand rests for `hold_s`). On this project's 2-core machine an
/// 800x1000 window's gem takes ~300 ms at full quality and ~60 ms moving (BENCHMARKS.md, "The
/// kiosk while the visitor turns the gem").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// The gem's resolution while moving, of the still one's (per side); egui scales it up.
    pub scale: f32,
    /// SSS taps per direction while moving (odd).
    pub sss_taps: usize,
    /// Seconds without a change before the still frame is drawn.
    pub hold_s: f32,
    /// The mesh while moving: simplified to about this many triangles
    /// ([`crate::render::Mesh::simplified`]), since on a CPU rasteriser a small frame's time
    /// goes on the triangles.
    pub max_triangles: usize,
}

/// The kiosk's [`Motion`].
pub const MOVING: Motion = Motion {
    scale: 0.5,
    sss_taps: 11,
    hold_s: 0.25,
    max_triangles: 15_000,
};

impl Motion {
    /// A moving frame's parameters from the still frame's (its size already scaled by the
    /// caller, who sizes the texture it goes to).
    pub fn apply(&self, still: RenderParams) -> RenderParams {
        RenderParams {
            antialias: false,
            sss: still.sss.map(|s| SssParams {
                taps: s.taps.min(self.sss_taps),
                ..s
            }),
            ..still
        }
    }
}

/// The orbit camera as the visitor moves it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub yaw_deg: f32,
    pub pitch_deg: f32,
    pub zoom: f32,
}

impl Default for Orbit {
    fn default() -> Self {
        Orbit {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            zoom: 1.0,
        }
    }
}

impl Orbit {
    /// A drag of (`dx`, `dy`) pixels: right turns the gem to show its right side, down tilts
    /// it towards the viewer's feet (the camera rises). Non-finite drags are ignored.
    pub fn drag(&mut self, dx: f32, dy: f32) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        self.yaw_deg = (self.yaw_deg - dx * DEGREES_PER_PIXEL).clamp(-MAX_YAW_DEG, MAX_YAW_DEG);
        self.pitch_deg =
            (self.pitch_deg + dy * DEGREES_PER_PIXEL).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    /// Multiplies the zoom (a pinch's ratio, or a wheel step's), within [`ZOOM_RANGE`].
    pub fn zoom_by(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.zoom = (self.zoom * factor).clamp(ZOOM_RANGE.0, ZOOM_RANGE.1);
        }
    }
}

/// How much of the default portrait to show, `since_face` seconds after a face was last seen:
/// 0 until `idle` seconds, then easing (smoothstep) to 1 over `ease` seconds.
pub fn idle_weight(since_face: f32, idle: f32, ease: f32) -> f32 {
    if !since_face.is_finite() {
        return 1.0;
    }
    if ease <= 0.0 {
        return if since_face >= idle { 1.0 } else { 0.0 };
    }
    let t = ((since_face - idle) / ease).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The face between the visitor's (`weight` 0) and the default (`weight` 1), vertex by vertex
/// (both are the same model's meshes); at the ends exactly one or the other, so the eased
/// portrait ends as the very default gem. `None` if they do not match.
pub fn blend_faces(face: &[f32], default: &[f32], weight: f32) -> Option<Vec<f32>> {
    if face.len() != default.len() || !weight.is_finite() {
        return None;
    }
    if weight >= 1.0 {
        return Some(default.to_vec());
    }
    let w = weight.max(0.0);
    Some(
        face.iter()
            .zip(default)
            .map(|(a, b)| a + (b - a) * w)
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<KioskConfig, ConfigError> {
        KioskConfig::parse(text, Path::new("kiosk.toml"))
    }

    #[test]
    fn the_controls_grow_with_a_wide_screen_only() {
        assert_eq!(controls_zoom(800, 1.0), 1.0);
        assert_eq!(controls_zoom(400, 1.0), 1.0);
        assert!((controls_zoom(1024, 1.0) - 1.28).abs() < 1e-6);
        assert!((controls_zoom(2048, 2.0) - 1.28).abs() < 1e-6);
        assert_eq!(controls_zoom(10_000, 1.0), 3.0);
        assert_eq!(controls_zoom(1024, 0.0), 3.0);
    }

    #[test]
    fn config_reads_every_key_and_defaults_the_rest() {
        let c = parse(
            "camera = 2\nmaterial = \"agate\"\nsss = false\nsss_strength = 0.3\n\
             idle_seconds = 5\nfullscreen = true\nportrait = \"frontal\"\nrender_scale = 0.5\n\
             lamp = true\nsetting = \"milgrain\"\nbail = true\n",
        )
        .expect("valid");
        // The lamp reaches the controls and the render; the border stays off.
        let controls = Controls::from_config(&c);
        assert!(controls.lamp && !controls.engraving);
        let l = Labels::default();
        assert_eq!(
            (controls.lamp_label(&l), controls.engraving_label(&l)),
            ("Lamp: on", "Border: off")
        );
        let p = controls.apply(&RenderParams::default(), &Orbit::default());
        assert!(p.lamp.is_some() && p.engraving.is_none());
        assert_eq!(c.camera, 2);
        assert_eq!(c.material, Material::Agate);
        assert_eq!(c.portrait, View::Frontal);
        // The setting reaches the gem thread's cameo.
        let cameo = c.cameo();
        assert_eq!(
            (cameo.setting, cameo.bail),
            (crate::gem::Setting::Milgrain, true)
        );
        assert_eq!(cameo.view, View::Frontal);
        assert!(parse("setting = \"filigree\"\n").is_err());
        assert!(!c.sss && c.fullscreen);
        assert_eq!(
            (c.sss_strength, c.idle_seconds, c.render_scale),
            (0.3, 5.0, 0.5)
        );
        assert_eq!(c.ease_seconds, KioskConfig::default().ease_seconds);
        assert_eq!(parse("").expect("empty is valid"), KioskConfig::default());
        // Full screen hides the cursor unless told otherwise; a window shows it.
        assert!(c.hides_cursor() && !KioskConfig::default().hides_cursor());
        assert!(
            !parse("fullscreen = true\nhide_cursor = false")
                .unwrap()
                .hides_cursor()
        );
        // The stipple: the photo path's depth by default, none at 0, twice as deep at 2.
        let deep = crate::gem::DetailParams::default().stipple_mm;
        assert_eq!(
            KioskConfig::default().detail(),
            crate::gem::DetailParams::default()
        );
        assert_eq!(parse("stipple = 0").unwrap().detail().stipple_mm, 0.0);
        assert_eq!(
            parse("stipple = 2").unwrap().detail().stipple_mm,
            2.0 * deep
        );
        // The engraved lines likewise; more than 3 refused.
        let lines = crate::gem::DetailParams::default().engraved_lines_mm;
        assert!(lines > 0.0);
        assert_eq!(
            parse("engraved_lines = 0")
                .unwrap()
                .detail()
                .engraved_lines_mm,
            0.0
        );
        assert_eq!(
            parse("engraved_lines = 2")
                .unwrap()
                .detail()
                .engraved_lines_mm,
            2.0 * lines
        );
        assert!(parse("engraved_lines = 3.5").is_err());
        // The darks' shadows: on by default, off at 0.
        assert_eq!(KioskConfig::default().detail().shadows, 1.0);
        assert_eq!(parse("shadows = 0").unwrap().detail().shadows, 0.0);
        assert_eq!(
            parse("photo_modelling = 0.5")
                .unwrap()
                .detail()
                .photo_modelling,
            0.5
        );
        assert!(parse("photo_modelling = 2").is_err());
        // The tone's match: on by default, off at 0, at most 3.
        assert_eq!(
            KioskConfig::default().detail().tone_match,
            crate::gem::TONE_MATCH
        );
        assert_eq!(parse("tone_match = 0").unwrap().detail().tone_match, 0.0);
        assert!(parse("tone_match = 4").is_err());
        // The visitor's words, one replaced, the others kept.
        let c = parse("attract_seconds = 45\n[texts]\nlook = \"Vaata kaamerasse\"\n").unwrap();
        assert_eq!(c.texts.get(Prompt::Look), "Vaata kaamerasse");
        assert_eq!(c.texts.carving, Texts::default().carving);
        assert_eq!(c.attract_seconds, 45.0);
        // The controls' labels too.
        let c = parse(
            "[labels]\nglow_on = \"Kuma: sees\"\nstyle = \"Stiil\"\nstyle_none = \"puudub\"\n",
        )
        .unwrap();
        let controls = Controls::from_config(&c);
        assert_eq!(controls.sss_label(&c.labels), "Kuma: sees");
        assert_eq!(controls.style_label(&c.labels), "Stiil: puudub");
        assert_eq!(controls.lamp_label(&c.labels), "Lamp: off");
    }

    #[test]
    fn bad_config_names_the_key_and_the_problem() {
        let msg = |text: &str| parse(text).expect_err(text).to_string();
        let m = msg("sss_strength = 3.0");
        assert!(m.contains("kiosk.toml") && m.contains("sss_strength") && m.contains("0..=1"));
        let m = msg("material = \"jade\"");
        assert!(m.contains("jade") || m.contains("material"), "{m}");
        let m = msg("idle_secs = 3");
        assert!(m.contains("idle_secs"), "{m}");
        let m = msg("width = 10");
        assert!(m.contains("width") && m.contains("64"), "{m}");
        let m = msg("render_scale = nan");
        assert!(m.contains("render_scale"), "{m}");
        let m = msg("stipple = 4");
        assert!(m.contains("stipple") && m.contains("0..=3"), "{m}");
        let m = msg("shadows = 1.5");
        assert!(m.contains("shadows") && m.contains("0..=1"), "{m}");
        let m = msg("[texts]\nlok = \"typo\"");
        assert!(m.contains("lok"), "{m}");
        let m = msg("[texts]\nyours = \"  \"");
        assert!(
            m.contains("texts") && m.contains("yours") && m.contains("empty"),
            "{m}"
        );
        let m = msg("[labels]\nmarble = \"\"");
        assert!(m.contains("labels") && m.contains("marble"), "{m}");
        let m = msg("[labels]\nagate = \"a very long name for a stone, more than a button holds\"");
        assert!(m.contains("agate") && m.contains("40"), "{m}");
        let m = msg("attract_seconds = 0");
        assert!(m.contains("attract_seconds"), "{m}");
        let m = msg("camera = [");
        assert!(m.contains("kiosk.toml"), "{m}");
        assert!(matches!(
            KioskConfig::load(Path::new("/nonexistent/kiosk.toml")),
            Err(ConfigError::Read { .. })
        ));
    }

    #[test]
    fn sss_label_shows_the_current_state() {
        let mut c = Controls::from_config(&KioskConfig::default());
        let l = Labels::default();
        assert!(c.sss && c.sss_label(&l).ends_with("on"));
        c.sss = false;
        assert!(c.sss_label(&l).ends_with("off"));
        let p = c.apply(&RenderParams::default(), &Orbit::default());
        assert!(p.sss.is_none());
        c.sss = true;
        c.sss_strength = 0.2;
        let p = c.apply(&RenderParams::default(), &Orbit::default());
        assert_eq!(p.sss.map(|s| s.strength[0]), Some(0.2));
        c.reset_strength();
        assert_eq!(c.sss_strength, DEFAULT_SSS_STRENGTH);
    }

    #[test]
    fn the_style_button_steps_through_the_styles_and_back() {
        let mut c = Controls::from_config(&KioskConfig::default());
        let l = Labels::default();
        assert_eq!(c.style_label(&l), "Style: none");
        let mut seen = Vec::new();
        for _ in 0..6 {
            c.next_style();
            seen.push(c.style_label(&l));
        }
        assert_eq!(
            seen,
            [
                "Style: toon",
                "Style: painterly",
                "Style: fisheye",
                "Style: chromatic",
                "Style: dither",
                "Style: none"
            ]
        );
        c.style = Some(Style::Toon);
        let p = c.apply(&RenderParams::default(), &Orbit::default());
        assert_eq!(p.styles, vec![Style::Toon]);
        // Only a moving style on a fast enough device is redrawn every frame.
        assert!(!c.animates(1.0));
        c.style = Some(Style::Chromatic);
        assert!(c.animates(ANIMATION_BUDGET_MS));
        assert!(!c.animates(400.0));
    }

    #[test]
    fn orbit_clamps_and_ignores_nonsense() {
        let mut o = Orbit::default();
        o.drag(100.0, 0.0);
        assert!((o.yaw_deg + 35.0).abs() < 1e-4);
        o.drag(-1e6, 1e6);
        assert_eq!((o.yaw_deg, o.pitch_deg), (MAX_YAW_DEG, MAX_PITCH_DEG));
        let before = o;
        o.drag(f32::NAN, 3.0);
        o.zoom_by(f32::INFINITY);
        o.zoom_by(-2.0);
        assert_eq!(o, before);
        o.zoom_by(100.0);
        assert_eq!(o.zoom, ZOOM_RANGE.1);
        o.zoom_by(1e-6);
        assert_eq!(o.zoom, ZOOM_RANGE.0);
    }

    #[test]
    fn idle_ease_goes_from_the_visitor_to_the_default() {
        assert_eq!(idle_weight(0.0, 8.0, 2.0), 0.0);
        assert_eq!(idle_weight(8.0, 8.0, 2.0), 0.0);
        assert!((idle_weight(9.0, 8.0, 2.0) - 0.5).abs() < 1e-6);
        assert_eq!(idle_weight(10.0, 8.0, 2.0), 1.0);
        assert_eq!(idle_weight(f32::INFINITY, 8.0, 2.0), 1.0);
        assert_eq!(idle_weight(7.9, 8.0, 0.0), 0.0);
        assert_eq!(idle_weight(8.0, 8.0, 0.0), 1.0);
        // At the end the default itself, bit for bit (a + (b - a) need not be b).
        let (x, y) = ([0.1f32], [0.3f32]);
        assert_eq!(blend_faces(&x, &y, 1.0), Some(y.to_vec()));
        let (a, b) = ([0.0, 2.0, 4.0], [2.0, 2.0, 0.0]);
        assert_eq!(blend_faces(&a, &b, 0.5), Some(vec![1.0, 2.0, 2.0]));
        assert_eq!(blend_faces(&a, &b, 0.0), Some(a.to_vec()));
        assert_eq!(blend_faces(&a, &b, 7.0), Some(b.to_vec()));
        assert_eq!(blend_faces(&a, &b[..2], 0.5), None);
    }
}
