//! Who is at the kiosk and what the screen says to them, free of windows and cameras: the
//! presence of a visitor (a face or a touch), the reset when they leave, the attract mode when
//! nobody has been there for a while, the visitor's prompt, and the staff's keys and gesture.
//!
//! Times are seconds since the kiosk started (`f64`), angles degrees. The window feeds faces,
//! touches and the clock in, and acts on the [`Change`]s that come out.
//!
//! Length: 544 lines of code, then its unit tests (243 lines), kept beside what they test.

use crate::render::Material;

use super::{KioskConfig, Orbit};

/// Whether anyone is at the kiosk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// A face or a touch within `idle_seconds`.
    Visitor,
    /// Nobody for `idle_seconds` (or since the start): the controls are as configured and the
    /// portrait eases back to the default face.
    Idle,
    /// Nobody for `attract_seconds`: the default gem turns slowly, changing stone, under a
    /// caption that invites the next visitor.
    Attract,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Visitor => "visitor",
            Mode::Idle => "idle",
            Mode::Attract => "attract",
        }
    }
}

/// What the window must do after a [`Presence`] step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Change {
    /// Somebody came (from idle or attract): the gem faces front again, the controls as
    /// configured.
    Arrived,
    /// The visitor left: every control back as configured, the portrait unfrozen and turned
    /// to the front, so the next visitor starts where everyone starts.
    Left,
    /// Nobody for long: the attract mode begins.
    Attract,
}

/// A visitor's presence: faces and touches in, [`Change`]s out.
#[derive(Clone, Debug)]
pub struct Presence {
    idle_s: f64,
    /// `None`: no attract mode.
    attract_s: Option<f64>,
    last_seen_s: f64,
    mode: Mode,
}

impl Presence {
    /// At start nobody has been seen: idle, the attract mode after `attract_seconds`.
    pub fn new(config: &KioskConfig, now_s: f64) -> Self {
        Presence {
            idle_s: f64::from(config.idle_seconds),
            attract_s: config.attract.then_some(f64::from(config.attract_seconds)),
            last_seen_s: if now_s.is_finite() { now_s } else { 0.0 },
            mode: Mode::Idle,
        }
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// A face in the camera or a touch on the screen at `now_s`.
    pub fn seen(&mut self, now_s: f64) -> Option<Change> {
        if !now_s.is_finite() {
            return None;
        }
        self.last_seen_s = self.last_seen_s.max(now_s);
        let arrived = self.mode != Mode::Visitor;
        self.mode = Mode::Visitor;
        arrived.then_some(Change::Arrived)
    }

    /// The clock at `now_s`: the visitor leaves after `idle_seconds` without a face or a
    /// touch; the attract mode starts `attract_seconds` after the last one.
    pub fn tick(&mut self, now_s: f64) -> Option<Change> {
        if !now_s.is_finite() {
            return None;
        }
        let quiet = now_s - self.last_seen_s;
        match self.mode {
            Mode::Visitor if quiet >= self.idle_s => {
                self.mode = Mode::Idle;
                Some(Change::Left)
            }
            Mode::Idle if self.attract_s.is_some_and(|a| quiet >= a) => {
                self.mode = Mode::Attract;
                Some(Change::Attract)
            }
            _ => None,
        }
    }
}

/// How the attract mode moves the gem: a slow swing that catches the light on the relief,
/// and the stone changing now and then.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attract {
    /// The swing's half-width and period, degrees and seconds.
    pub yaw_deg: f32,
    pub yaw_period_s: f64,
    /// A slower nod.
    pub pitch_deg: f32,
    pub pitch_period_s: f64,
    /// Seconds on each stone.
    pub material_s: f64,
    /// The least time between two attract frames (30 a second).
    pub min_frame_s: f64,
    /// The share of the time the attract mode may spend drawing: on a CPU rasteriser a
    /// moving frame costs ~60 ms, and the face thread needs the cores to see the next visitor.
    pub busy_share: f64,
}

/// The kiosk's [`Attract`].
pub const ATTRACT: Attract = Attract {
    yaw_deg: 24.0,
    yaw_period_s: 16.0,
    pitch_deg: 5.0,
    pitch_period_s: 27.0,
    material_s: 24.0,
    min_frame_s: 1.0 / 30.0,
    busy_share: 0.3,
};

impl Attract {
    /// Seconds between two attract frames when the last gem frame took `render_ms`: about
    /// 5 a second on a CPU rasteriser (~60 ms a frame), 30 on a GPU.
    pub fn frame_interval(&self, render_ms: f64) -> f64 {
        let busy = if render_ms.is_finite() {
            render_ms.max(0.0)
        } else {
            0.0
        };
        (busy / 1e3 / self.busy_share).clamp(self.min_frame_s, 2.0)
    }

    /// The orbit `t_s` seconds into the attract mode: it starts facing front, at rest.
    pub fn orbit(&self, t_s: f64) -> Orbit {
        let t = if t_s.is_finite() { t_s.max(0.0) } else { 0.0 };
        let wave = |period: f64| (std::f64::consts::TAU * t / period).sin() as f32;
        Orbit {
            yaw_deg: self.yaw_deg * wave(self.yaw_period_s),
            pitch_deg: self.pitch_deg * wave(self.pitch_period_s),
            zoom: 1.0,
        }
    }

    /// The stone `t_s` seconds into the attract mode: the configured one first, then the
    /// others in [`Material::ALL`]'s order, in turn.
    pub fn material(&self, t_s: f64, configured: Material) -> Material {
        let turn = if t_s.is_finite() && t_s > 0.0 {
            (t_s / self.material_s) as u64
        } else {
            0
        };
        let all = Material::ALL;
        let first = all.iter().position(|&m| m == configured).unwrap_or(0);
        all[(first + (turn % all.len() as u64) as usize) % all.len()]
    }
}

/// What the visitor is told, on the top line (and, in attract mode, as a caption on the gem).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prompt {
    /// The models are still loading.
    Preparing,
    /// No camera (or no face tracking in this build): the default gem is shown.
    Resting,
    /// Nobody in the camera.
    Look,
    /// A face is seen; its gem is not shown yet.
    Carving,
    /// The visitor's gem is shown.
    Yours,
    /// The visitor froze the portrait.
    Kept,
    /// Nobody for long.
    Attract,
}

impl Prompt {
    pub fn name(self) -> &'static str {
        match self {
            Prompt::Preparing => "preparing",
            Prompt::Resting => "resting",
            Prompt::Look => "look",
            Prompt::Carving => "carving",
            Prompt::Yours => "yours",
            Prompt::Kept => "kept",
            Prompt::Attract => "attract",
        }
    }
}

/// What the window knows when it chooses the prompt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Situation {
    /// The gem thread has its model (a gem can be made).
    pub ready: bool,
    /// Frames are coming from a camera or video, and faces are looked for.
    pub camera: bool,
    pub mode: Mode,
    /// The newest frame had a face.
    pub face: bool,
    /// The gem on screen was made from the visitor's face (not the default, nor an ease).
    pub visitor_gem: bool,
    pub frozen: bool,
}

/// The prompt for a situation: never an error or a number (those go to the staff panel and
/// the log).
pub fn prompt(s: &Situation) -> Prompt {
    if !s.ready {
        Prompt::Preparing
    } else if s.frozen {
        Prompt::Kept
    } else if s.mode == Mode::Attract {
        Prompt::Attract
    } else if !s.camera {
        Prompt::Resting
    } else if s.face && s.visitor_gem {
        Prompt::Yours
    } else if s.face {
        Prompt::Carving
    } else {
        Prompt::Look
    }
}

/// The visitor's words, one per [`Prompt`] plus the attract caption's title; each may be
/// replaced in the configuration's `[texts]` table (another language, the museum's voice).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Texts {
    pub preparing: String,
    pub resting: String,
    pub look: String,
    pub carving: String,
    pub yours: String,
    pub kept: String,
    /// The attract caption's first line, large.
    pub attract_title: String,
    /// Its second line (also the top line in attract mode).
    pub attract: String,
    /// Said for a few seconds after "Save picture".
    pub saved: String,
    pub not_saved: String,
}

impl Default for Texts {
    fn default() -> Self {
        Texts {
            preparing: "Preparing the stone…".into(),
            resting: "A classical cameo: touch the buttons to change its stone and light".into(),
            look: "Look at the camera to be carved in stone".into(),
            carving: "Hold still: your cameo is being carved".into(),
            yours: "Your cameo! Drag it to turn it in the light".into(),
            kept: "Your portrait is kept. Press “Portrait: frozen” to carve a new one".into(),
            attract_title: "Become a cameo".into(),
            attract: "Step closer and look at the camera".into(),
            saved: "Picture saved".into(),
            not_saved: "The picture could not be saved: please ask the staff".into(),
        }
    }
}

impl Texts {
    pub fn get(&self, p: Prompt) -> &str {
        match p {
            Prompt::Preparing => &self.preparing,
            Prompt::Resting => &self.resting,
            Prompt::Look => &self.look,
            Prompt::Carving => &self.carving,
            Prompt::Yours => &self.yours,
            Prompt::Kept => &self.kept,
            Prompt::Attract => &self.attract,
        }
    }

    /// The first text that is empty or too long for the top line, by its key.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        [
            ("preparing", &self.preparing),
            ("resting", &self.resting),
            ("look", &self.look),
            ("carving", &self.carving),
            ("yours", &self.yours),
            ("kept", &self.kept),
            ("attract_title", &self.attract_title),
            ("attract", &self.attract),
            ("saved", &self.saved),
            ("not_saved", &self.not_saved),
        ]
        .into_iter()
        .find_map(|(key, text)| too_long_or_empty(key, text, MAX_TEXT_CHARS))
    }
}

/// The controls' labels; each may be replaced in the configuration's `[labels]` table. The
/// toggles say the state they are in ("Glow: on"), the style button its style ("Style: none";
/// the styles' own names stay as they are).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Labels {
    pub marble: String,
    pub agate: String,
    pub shell: String,
    pub jasperware: String,
    pub glow_on: String,
    pub glow_off: String,
    pub glow_strength: String,
    pub reset_glow: String,
    pub portrait_live: String,
    pub portrait_frozen: String,
    pub save: String,
    pub front: String,
    pub style: String,
    pub style_none: String,
    pub border_on: String,
    pub border_off: String,
    pub lamp_on: String,
    pub lamp_off: String,
}

impl Default for Labels {
    fn default() -> Self {
        let s = |t: &str| t.to_string();
        Labels {
            marble: s("Marble"),
            agate: s("Agate"),
            shell: s("Shell"),
            jasperware: s("Jasper"),
            glow_on: s("Glow: on"),
            glow_off: s("Glow: off"),
            glow_strength: s("Glow strength"),
            reset_glow: s("Reset glow"),
            portrait_live: s("Portrait: live"),
            portrait_frozen: s("Portrait: frozen"),
            save: s("Save picture"),
            front: s("Front view"),
            style: s("Style"),
            style_none: s("none"),
            border_on: s("Border: on"),
            border_off: s("Border: off"),
            lamp_on: s("Lamp: on"),
            lamp_off: s("Lamp: off"),
        }
    }
}

/// The longest label: a button that still fits a row of three on a narrow screen.
pub const MAX_LABEL_CHARS: usize = 40;

impl Labels {
    /// A stone's button.
    pub fn stone(&self, material: Material) -> &str {
        match material {
            Material::Marble => &self.marble,
            Material::Agate => &self.agate,
            Material::Shell => &self.shell,
            Material::Jasperware => &self.jasperware,
        }
    }

    /// The first label that is empty or too long, by its key.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        [
            ("marble", &self.marble),
            ("agate", &self.agate),
            ("shell", &self.shell),
            ("jasperware", &self.jasperware),
            ("glow_on", &self.glow_on),
            ("glow_off", &self.glow_off),
            ("glow_strength", &self.glow_strength),
            ("reset_glow", &self.reset_glow),
            ("portrait_live", &self.portrait_live),
            ("portrait_frozen", &self.portrait_frozen),
            ("save", &self.save),
            ("front", &self.front),
            ("style", &self.style),
            ("style_none", &self.style_none),
            ("border_on", &self.border_on),
            ("border_off", &self.border_off),
            ("lamp_on", &self.lamp_on),
            ("lamp_off", &self.lamp_off),
        ]
        .into_iter()
        .find_map(|(key, text)| too_long_or_empty(key, text, MAX_LABEL_CHARS))
    }
}

/// `Some((key, problem))` for an empty text or one over `max` characters.
fn too_long_or_empty(key: &'static str, text: &str, max: usize) -> Option<(&'static str, String)> {
    let n = text.chars().count();
    if text.trim().is_empty() {
        Some((key, "is empty".to_string()))
    } else if n > max {
        Some((key, format!("is {n} characters, more than {max}")))
    } else {
        None
    }
}

/// The longest visitor text: about two lines at the top line's size on a narrow screen.
pub const MAX_TEXT_CHARS: usize = 120;

/// A key press the kiosk answers, by its name as the window reports it ("q", "s", "F12",
/// "Escape"; letters in either case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StaffAction {
    /// Leave the kiosk (exit 0: a supervisor that restarts on failure leaves it stopped).
    Quit,
    /// Show or hide the staff panel (timings, errors, the quit button).
    TogglePanel,
    ClosePanel,
}

/// The staff's keys: Ctrl+Shift+Q quits and Ctrl+Shift+S (or F12) shows the staff panel,
/// chords a visitor does not press by chance on a keyboard left out; Escape closes the panel,
/// and in a window (not full screen, a developer's) quits.
pub fn staff_action(
    key: &str,
    ctrl: bool,
    shift: bool,
    panel_open: bool,
    fullscreen: bool,
) -> Option<StaffAction> {
    let chord = ctrl && shift;
    match key.to_ascii_lowercase().as_str() {
        "q" if chord => Some(StaffAction::Quit),
        "s" if chord => Some(StaffAction::TogglePanel),
        "f12" => Some(StaffAction::TogglePanel),
        "escape" if panel_open => Some(StaffAction::ClosePanel),
        "escape" if !fullscreen => Some(StaffAction::Quit),
        _ => None,
    }
}

/// Wrong PINs in a row before the pad pauses.
pub const PIN_TRIES: u32 = 3;
/// The first pause after [`PIN_TRIES`] wrong PINs, seconds; each pause after it doubles, up
/// to [`PIN_MAX_PAUSE_S`]. A right PIN clears both.
pub const PIN_PAUSE_S: f64 = 30.0;
pub const PIN_MAX_PAUSE_S: f64 = 900.0;

/// What a PIN typed on the staff pad did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PinOutcome {
    /// The right PIN: the staff panel opens.
    Open,
    /// A wrong one; this many tries before a pause.
    Wrong { tries_left: u32 },
    /// Too many wrong ones (this one included, or it came during a pause, unread): the pad
    /// takes nothing for this many seconds.
    Paused { seconds: f64 },
}

/// The lock on the staff panel where a PIN is configured: a few tries, then a pause that
/// doubles each time (a visitor trying PINs at the screen gets a handful an hour). Times are
/// the kiosk's seconds.
#[derive(Clone, Debug, Default)]
pub struct PinGate {
    wrong: u32,
    pauses: u32,
    paused_until: f64,
}

impl PinGate {
    /// Seconds the pad is still paused at `now_s` (`None`: it takes a PIN).
    pub fn paused(&self, now_s: f64) -> Option<f64> {
        (now_s < self.paused_until).then_some(self.paused_until - now_s)
    }

    /// `attempt` typed at `now_s`, checked against `pin` (not at all during a pause).
    pub fn submit(&mut self, pin: &crate::pin::StaffPin, attempt: &str, now_s: f64) -> PinOutcome {
        if let Some(seconds) = self.paused(now_s) {
            return PinOutcome::Paused { seconds };
        }
        if pin.matches(attempt) {
            *self = PinGate::default();
            return PinOutcome::Open;
        }
        self.wrong += 1;
        if self.wrong < PIN_TRIES {
            return PinOutcome::Wrong {
                tries_left: PIN_TRIES - self.wrong,
            };
        }
        let seconds = (PIN_PAUSE_S * 2f64.powi(self.pauses.min(16) as i32)).min(PIN_MAX_PAUSE_S);
        self.wrong = 0;
        self.pauses += 1;
        self.paused_until = now_s + seconds;
        PinOutcome::Paused { seconds }
    }
}

/// The staff's gesture on a touch screen: a finger held on the screen's top-left corner for
/// `hold_s` opens the staff panel (once per hold).
#[derive(Clone, Debug)]
pub struct HoldGesture {
    pub hold_s: f64,
    since: Option<f64>,
    fired: bool,
}

/// Seconds the corner must be held: longer than any visitor's tap or drag.
pub const STAFF_HOLD_S: f64 = 4.0;

impl HoldGesture {
    pub fn new(hold_s: f64) -> Self {
        HoldGesture {
            hold_s,
            since: None,
            fired: false,
        }
    }

    /// The finger's state at `now_s` (`held`: down, and pressed within the corner); true
    /// once when the hold is long enough.
    pub fn update(&mut self, now_s: f64, held: bool) -> bool {
        if !held || !now_s.is_finite() {
            self.since = None;
            self.fired = false;
            return false;
        }
        let since = *self.since.get_or_insert(now_s);
        if !self.fired && now_s - since >= self.hold_s {
            self.fired = true;
            return true;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(idle: f32, attract: f32) -> KioskConfig {
        KioskConfig {
            idle_seconds: idle,
            attract_seconds: attract,
            ..KioskConfig::default()
        }
    }

    #[test]
    fn a_visitor_arrives_leaves_and_the_attract_mode_follows() {
        let mut p = Presence::new(&config(8.0, 30.0), 0.0);
        assert_eq!(p.mode(), Mode::Idle);
        assert_eq!(p.tick(29.9), None);
        assert_eq!(p.tick(30.0), Some(Change::Attract));
        assert_eq!(p.tick(31.0), None, "said once");
        assert_eq!(p.seen(40.0), Some(Change::Arrived));
        assert_eq!(p.seen(41.0), None, "a visitor stays a visitor");
        // Faces and touches keep the visitor; the clock alone lets them go.
        assert_eq!(p.tick(48.9), None);
        assert_eq!(p.tick(49.0), Some(Change::Left));
        assert_eq!(p.mode(), Mode::Idle);
        assert_eq!(p.tick(70.9), None);
        assert_eq!(p.tick(71.0), Some(Change::Attract));
        // Somebody back during the ease: arrived, not left twice.
        assert_eq!(p.seen(72.0), Some(Change::Arrived));
        assert_eq!(p.tick(80.0), Some(Change::Left));
        assert_eq!(p.seen(81.0), Some(Change::Arrived));
        // Nonsense clocks change nothing; a face from the past does not move the clock back.
        assert_eq!(p.tick(f64::NAN), None);
        assert_eq!(p.seen(f64::INFINITY), None);
        p.seen(10.0);
        assert_eq!(p.tick(88.9), None);
        assert_eq!(p.tick(89.0), Some(Change::Left));
    }

    #[test]
    fn without_attract_mode_the_kiosk_stays_idle() {
        let c = KioskConfig {
            attract: false,
            ..config(1.0, 2.0)
        };
        let mut p = Presence::new(&c, 0.0);
        assert_eq!(p.tick(1e6), None);
        assert_eq!(p.seen(1e6), Some(Change::Arrived));
        assert_eq!(p.tick(1e6 + 1.0), Some(Change::Left));
        assert_eq!(p.tick(1e7), None);
    }

    #[test]
    fn the_attract_swing_starts_at_rest_and_stays_within_its_bounds() {
        assert_eq!(ATTRACT.orbit(0.0), Orbit::default());
        assert_eq!(ATTRACT.orbit(f64::NAN), Orbit::default());
        let quarter = ATTRACT.orbit(ATTRACT.yaw_period_s / 4.0);
        assert!((quarter.yaw_deg - ATTRACT.yaw_deg).abs() < 1e-3);
        for i in 0..1000 {
            let o = ATTRACT.orbit(f64::from(i) * 0.37);
            assert!(o.yaw_deg.abs() <= ATTRACT.yaw_deg + 1e-4);
            assert!(o.pitch_deg.abs() <= ATTRACT.pitch_deg + 1e-4);
            assert!(o.yaw_deg.abs() <= super::super::MAX_YAW_DEG);
        }
        // About 5 frames a second on a CPU rasteriser, 30 on a GPU, never stuck.
        assert!((ATTRACT.frame_interval(60.0) - 0.2).abs() < 1e-9);
        assert_eq!(ATTRACT.frame_interval(2.0), ATTRACT.min_frame_s);
        assert_eq!(ATTRACT.frame_interval(f64::NAN), ATTRACT.min_frame_s);
        assert_eq!(ATTRACT.frame_interval(1e9), 2.0);
        // Small steps between frames: under 2 degrees at the CPU's rate.
        let step = (0..1000)
            .map(|i| {
                let t = f64::from(i) * 0.1;
                let (a, b) = (
                    ATTRACT.orbit(t),
                    ATTRACT.orbit(t + ATTRACT.frame_interval(60.0)),
                );
                (a.yaw_deg - b.yaw_deg).abs()
            })
            .fold(0.0f32, f32::max);
        assert!(step < 2.0, "{step}");
        let m = |t| ATTRACT.material(t, Material::Marble);
        assert_eq!(m(0.0), Material::Marble);
        assert_eq!(m(ATTRACT.material_s + 0.1), Material::Agate);
        // Every stone in turn, then the configured one again.
        assert_eq!(m(2.0 * ATTRACT.material_s + 0.1), Material::Shell);
        assert_eq!(m(3.0 * ATTRACT.material_s + 0.1), Material::Jasperware);
        assert_eq!(m(4.0 * ATTRACT.material_s + 0.1), Material::Marble);
        assert_eq!(
            ATTRACT.material(ATTRACT.material_s + 0.1, Material::Jasperware),
            Material::Marble
        );
        assert_eq!(ATTRACT.material(1.0, Material::Agate), Material::Agate);
        assert_eq!(m(f64::NAN), Material::Marble);
    }

    #[test]
    fn the_prompt_tells_the_visitor_what_to_do_and_never_an_error() {
        let s = Situation {
            ready: true,
            camera: true,
            mode: Mode::Visitor,
            face: false,
            visitor_gem: false,
            frozen: false,
        };
        let p = |f: &dyn Fn(&mut Situation)| {
            let mut s = s;
            f(&mut s);
            prompt(&s)
        };
        assert_eq!(p(&|_| {}), Prompt::Look);
        assert_eq!(p(&|s| s.face = true), Prompt::Carving);
        assert_eq!(
            p(&|s| {
                s.face = true;
                s.visitor_gem = true
            }),
            Prompt::Yours
        );
        assert_eq!(p(&|s| s.ready = false), Prompt::Preparing);
        assert_eq!(p(&|s| s.camera = false), Prompt::Resting);
        assert_eq!(p(&|s| s.mode = Mode::Attract), Prompt::Attract);
        assert_eq!(
            p(&|s| {
                s.frozen = true;
                s.face = true
            }),
            Prompt::Kept
        );
        let texts = Texts::default();
        for prompt in [
            Prompt::Preparing,
            Prompt::Resting,
            Prompt::Look,
            Prompt::Carving,
            Prompt::Yours,
            Prompt::Kept,
            Prompt::Attract,
        ] {
            let t = texts.get(prompt);
            assert!(!t.is_empty() && t.chars().count() <= MAX_TEXT_CHARS);
            assert!(!t.contains("error") && !t.contains(" ms") && !t.contains('/'));
        }
        assert_eq!(texts.problem(), None);
        let long = Texts {
            yours: "x".repeat(MAX_TEXT_CHARS + 1),
            ..Texts::default()
        };
        assert_eq!(long.problem().map(|p| p.0), Some("yours"));
    }

    #[test]
    fn staff_keys_are_chords_and_escape_depends_on_the_screen() {
        use StaffAction::*;
        assert_eq!(staff_action("q", true, true, false, true), Some(Quit));
        assert_eq!(staff_action("Q", true, true, false, true), Some(Quit));
        assert_eq!(staff_action("q", true, false, false, true), None);
        assert_eq!(staff_action("q", false, false, false, false), None);
        assert_eq!(
            staff_action("s", true, true, false, true),
            Some(TogglePanel)
        );
        assert_eq!(
            staff_action("F12", false, false, true, true),
            Some(TogglePanel)
        );
        assert_eq!(
            staff_action("Escape", false, false, true, true),
            Some(ClosePanel)
        );
        assert_eq!(staff_action("Escape", false, false, false, true), None);
        assert_eq!(
            staff_action("Escape", false, false, false, false),
            Some(Quit)
        );
        assert_eq!(staff_action("a", true, true, false, false), None);
    }

    #[test]
    fn the_staff_gesture_needs_a_long_hold_and_fires_once() {
        let mut g = HoldGesture::new(STAFF_HOLD_S);
        assert!(!g.update(0.0, true));
        assert!(!g.update(3.9, true));
        assert!(g.update(4.0, true));
        assert!(!g.update(9.0, true), "once per hold");
        assert!(!g.update(9.1, false));
        assert!(!g.update(10.0, true));
        // A lift in between starts the count again.
        assert!(!g.update(12.0, false));
        assert!(!g.update(13.0, true));
        assert!(!g.update(16.9, true));
        assert!(g.update(17.0, true));
        assert!(!g.update(f64::NAN, true));
    }

    #[test]
    fn the_pin_pad_pauses_after_a_few_wrong_pins_and_longer_each_time() {
        let pin = crate::pin::StaffPin::new("4711", [3; 16]).unwrap();
        let mut gate = PinGate::default();
        assert_eq!(
            gate.submit(&pin, "0000", 0.0),
            PinOutcome::Wrong { tries_left: 2 }
        );
        assert_eq!(gate.submit(&pin, "4711", 1.0), PinOutcome::Open);
        // A right PIN forgets the wrong ones: three more before a pause.
        assert_eq!(
            gate.submit(&pin, "1", 2.0),
            PinOutcome::Wrong { tries_left: 2 }
        );
        assert_eq!(
            gate.submit(&pin, "2", 3.0),
            PinOutcome::Wrong { tries_left: 1 }
        );
        assert_eq!(
            gate.submit(&pin, "3", 4.0),
            PinOutcome::Paused { seconds: 30.0 }
        );
        // During the pause even the right PIN is not read.
        assert_eq!(gate.paused(20.0), Some(14.0));
        assert_eq!(
            gate.submit(&pin, "4711", 20.0),
            PinOutcome::Paused { seconds: 14.0 }
        );
        // After it, three tries again, then twice the pause; and so on up to the cap.
        for (k, pause) in [(0, 60.0), (1, 120.0), (2, 240.0), (3, 480.0), (4, 900.0)] {
            let t = 1e4 * f64::from(k + 1);
            assert_eq!(gate.paused(t), None);
            gate.submit(&pin, "9", t);
            gate.submit(&pin, "9", t);
            assert_eq!(
                gate.submit(&pin, "9", t),
                PinOutcome::Paused { seconds: pause }
            );
        }
        assert_eq!(gate.submit(&pin, "4711", 1e6), PinOutcome::Open);
        assert_eq!(
            gate.submit(&pin, "9", 1e6),
            PinOutcome::Wrong { tries_left: 2 }
        );
    }
}
