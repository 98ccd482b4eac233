//! The kiosk's controls (egui): finger-sized, three rows under the gem, drags on the gem orbit
//! it. Each control's rectangle is kept for scripted runs (`--trace`).

use glyptic::kiosk::{Controls, Labels, Orbit};
use glyptic::render::Material;

/// Finger-sized controls: 56-point buttons, a thick slider, large text, a gold pressed state. A press counts as a
/// tap however long it is held (visitors press slowly, and a CPU-rendered frame can take half
/// a second) and however much a finger wobbles.
pub(super) fn style(ctx: &egui::Context) {
    ctx.options_mut(|o| {
        o.input_options.max_click_duration = 5.0;
        o.input_options.max_click_dist = 12.0;
    });
    ctx.global_style_mut(|s| {
        s.spacing.interact_size = egui::vec2(56.0, 56.0);
        s.spacing.button_padding = egui::vec2(18.0, 12.0);
        s.spacing.item_spacing = egui::vec2(12.0, 10.0);
        s.spacing.slider_width = 260.0;
        s.spacing.slider_rail_height = 14.0;
        // Buttons look like buttons: a raised grey face with a light rim and round corners
        // (egui's default shows an unselected button as bare text); the chosen one is gold
        // with dark text.
        let face = egui::Color32::from_rgb(0x3b, 0x3f, 0x47);
        let rim = egui::Stroke::new(1.5, egui::Color32::from_rgb(0xa4, 0xa9, 0xb3));
        for (w, lift) in [
            (&mut s.visuals.widgets.inactive, 0u8),
            (&mut s.visuals.widgets.hovered, 14),
        ] {
            let c = egui::Color32::from_rgb(face.r() + lift, face.g() + lift, face.b() + lift);
            w.bg_fill = c;
            w.weak_bg_fill = c;
            w.bg_stroke = rim;
            w.corner_radius = egui::CornerRadius::same(12);
            w.fg_stroke = egui::Stroke::new(1.5, egui::Color32::from_rgb(0xf0, 0xf0, 0xf0));
        }
        s.visuals.widgets.active.corner_radius = egui::CornerRadius::same(12);
        s.visuals.selection.bg_fill = egui::Color32::from_rgb(0xd4, 0xa7, 0x3c);
        s.visuals.selection.stroke =
            egui::Stroke::new(2.0, egui::Color32::from_rgb(0x14, 0x10, 0x08));
        // Pressed: gold and a little larger, so a finger sees its tap land.
        let pressed = &mut s.visuals.widgets.active;
        pressed.bg_fill = egui::Color32::from_rgb(0xc9, 0x9a, 0x2e);
        pressed.weak_bg_fill = pressed.bg_fill;
        pressed.fg_stroke = egui::Stroke::new(2.0, egui::Color32::BLACK);
        pressed.expansion = 4.0;
        for (text_style, size) in [
            (egui::TextStyle::Button, 24.0),
            (egui::TextStyle::Body, 22.0),
            (egui::TextStyle::Small, 18.0),
        ] {
            if let Some(font) = s.text_styles.get_mut(&text_style) {
                font.size = size;
            }
        }
    });
}

/// A button that shows `on` as selected and flips it when pressed; `label` says the state.
fn toggle(ui: &mut egui::Ui, on: &mut bool, label: &str) -> egui::Response {
    let r = ui.add(egui::Button::new(label).selected(*on));
    if r.clicked() {
        *on = !*on;
    }
    r
}

/// What the staff panel shows: figures and the recent problems (the visitor sees neither).
pub(super) struct StaffView {
    /// (what, value) rows.
    pub(super) rows: Vec<(&'static str, String)>,
    /// The newest problems, oldest first.
    pub(super) log: Vec<String>,
}

/// What the staff's PIN pad shows: a dot per digit typed and its last word.
pub(super) struct PadView {
    pub(super) dots: usize,
    pub(super) said: String,
}

/// One frame of the controls.
pub(super) struct UiFrame<'a> {
    pub(super) controls: &'a mut Controls,
    pub(super) labels: &'a Labels,
    pub(super) orbit: &'a mut Orbit,
    pub(super) layer: Option<egui::TextureId>,
    /// The visitor's line at the top.
    pub(super) prompt: String,
    /// The attract mode's caption over the gem (title, line).
    pub(super) caption: Option<(String, String)>,
    /// The staff panel, when open.
    pub(super) staff: Option<StaffView>,
    /// The PIN pad, while it asks; what was pressed on it this frame.
    pub(super) pad: Option<PadView>,
    pub(super) pad_inputs: Vec<super::staff::PadInput>,
    pub(super) toast: Option<String>,
    /// Where the gem is shown (points).
    pub(super) gem_rect: Option<egui::Rect>,
    pub(super) snapshot: bool,
    /// The staff panel's buttons: close it, quit the kiosk.
    pub(super) close_staff: bool,
    pub(super) quit: bool,
    /// A finger or the mouse is down, pressed within the top-left corner (the staff gesture).
    pub(super) corner_held: bool,
    /// Where each control is (points), for scripted runs.
    pub(super) rects: Vec<(&'static str, egui::Rect)>,
}

/// The text colour on the dark panels (egui's "strong" colour is the pressed button's dark
/// text here).
const LIGHT: egui::Color32 = egui::Color32::from_rgb(0xf2, 0xec, 0xe0);

/// The staff gesture's corner, points from the window's top-left.
const CORNER: f32 = 90.0;

impl UiFrame<'_> {
    pub(super) fn draw(&mut self, root: &mut egui::Ui) {
        let ctx = root.ctx().clone();
        self.corner_held = ctx.input(|i| {
            let corner = i
                .pointer
                .press_origin()
                .is_some_and(|p| p.x < CORNER && p.y < CORNER);
            i.pointer.any_down() && corner
        });
        egui::Panel::top("prompt").show(root, |ui| {
            ui.add_space(4.0);
            ui.vertical_centered(|ui| {
                ui.add(
                    egui::Label::new(egui::RichText::new(&self.prompt).size(26.0).color(LIGHT))
                        .wrap(),
                );
            });
            ui.add_space(4.0);
        });
        egui::Panel::bottom("controls").show(root, |ui| {
            ui.add_space(6.0);
            // Three rows: the stone, the glow, the portrait. The stones' row wraps (the glow
            // toggle goes under the four stones) on a narrow window.
            ui.horizontal_wrapped(|ui| {
                for material in Material::ALL {
                    let (name, key) = (self.labels.stone(material), material.name());
                    let on = self.controls.material == material;
                    let r = ui.add(egui::Button::new(name).selected(on));
                    if r.clicked() {
                        self.controls.material = material;
                    }
                    self.rects.push((key, r.rect));
                }
                ui.separator();
                let label = self.controls.sss_label(self.labels);
                let r = toggle(ui, &mut self.controls.sss, label);
                self.rects.push(("sss", r.rect));
            });
            ui.horizontal(|ui| {
                // A label, the slider, its reset: the slider takes the row but their room.
                let label = ui.add_enabled(
                    self.controls.sss,
                    egui::Label::new(egui::RichText::new(&self.labels.glow_strength).color(LIGHT)),
                );
                self.rects.push(("strength_label", label.rect));
                ui.spacing_mut().slider_width = (ui.available_width() - 190.0).clamp(120.0, 600.0);
                let r = ui.add_enabled(
                    self.controls.sss,
                    egui::Slider::new(&mut self.controls.sss_strength, 0.0..=1.0).show_value(false),
                );
                self.rects.push(("strength", r.rect));
                let r = ui.add_enabled(
                    self.controls.sss,
                    egui::Button::new(self.labels.reset_glow.as_str()),
                );
                if r.clicked() {
                    self.controls.reset_strength();
                }
                self.rects.push(("reset", r.rect));
            });
            ui.horizontal(|ui| {
                let label = self.controls.freeze_label(self.labels);
                let r = toggle(ui, &mut self.controls.frozen, label);
                self.rects.push(("freeze", r.rect));
                let r = ui.button(self.labels.save.as_str());
                if r.clicked() {
                    self.snapshot = true;
                }
                self.rects.push(("save", r.rect));
                let r = ui.button(self.labels.front.as_str());
                if r.clicked() {
                    *self.orbit = Orbit::default();
                }
                self.rects.push(("front", r.rect));
            });
            ui.horizontal(|ui| {
                let r = ui.add(
                    egui::Button::new(self.controls.style_label(self.labels))
                        .selected(self.controls.style.is_some()),
                );
                if r.clicked() {
                    self.controls.next_style();
                }
                self.rects.push(("style", r.rect));
                let label = self.controls.engraving_label(self.labels);
                let r = toggle(ui, &mut self.controls.engraving, label);
                self.rects.push(("border", r.rect));
                let label = self.controls.lamp_label(self.labels);
                let r = toggle(ui, &mut self.controls.lamp, label);
                self.rects.push(("lamp", r.rect));
            });
            // The toast's line is always there, so that a message never moves the buttons
            // up under the visitor's finger (a second tap on Save missed it).
            ui.label(self.toast.as_deref().unwrap_or(" "));
            ui.add_space(6.0);
        });
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(root, |ui| {
                let rect = ui.max_rect();
                self.gem_rect = Some(rect);
                self.rects.push(("gem", rect));
                if let Some(id) = self.layer {
                    ui.painter().image(
                        id,
                        rect,
                        egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                        egui::Color32::WHITE,
                    );
                }
                if let Some((title, line)) = &self.caption {
                    caption(ui.painter(), rect, title, line);
                }
                // Orbit and zoom only on the gem itself: a drag that starts on a control
                // belongs to the control, so the camera never moves while a slider is dragged.
                let response = ui.interact(rect, egui::Id::unique("gem view"), egui::Sense::drag());
                if response.dragged() {
                    let d = response.drag_delta();
                    self.orbit.drag(d.x, d.y);
                }
                if response.hovered() || response.dragged() {
                    let (zoom, scroll) = ui.input(|i| (i.zoom_delta(), i.smooth_scroll_delta.y));
                    if zoom != 1.0 {
                        self.orbit.zoom_by(zoom);
                    }
                    if scroll != 0.0 {
                        self.orbit.zoom_by((scroll / 400.0).exp());
                    }
                }
            });
        if let Some(staff) = &self.staff {
            let (close, quit) = staff_panel(&ctx, staff);
            self.close_staff |= close;
            self.quit |= quit;
        }
        if let Some(pad) = &self.pad {
            self.pad_inputs.extend(pin_pad(&ctx, pad));
        }
    }
}

/// The staff's PIN pad: big keys a finger hits (1-9, back, 0, OK; Cancel), the digits as
/// dots. What was pressed this frame.
fn pin_pad(ctx: &egui::Context, pad: &PadView) -> Vec<super::staff::PadInput> {
    use super::staff::PadInput;
    let mut pressed = Vec::new();
    let text = |s: &str, size: f32| egui::RichText::new(s).size(size).color(LIGHT);
    egui::Area::new(egui::Id::unique("pin pad"))
        .anchor(egui::Align2::CENTER_CENTER, egui::vec2(0.0, 0.0))
        .order(egui::Order::Foreground)
        .show(ctx, |ui| {
            egui::Frame::window(ui.style())
                .fill(egui::Color32::from_rgba_unmultiplied(16, 18, 22, 245))
                .inner_margin(egui::Margin::same(20))
                .show(ui, |ui| {
                    ui.vertical_centered(|ui| {
                        ui.label(text(&pad.said, 22.0));
                        // (egui's fonts have no bullet glyphs.)
                        let dots = "* ".repeat(pad.dots);
                        ui.label(text(if dots.is_empty() { " " } else { &dots }, 28.0));
                        ui.add_space(8.0);
                    });
                    let key = egui::vec2(96.0, 72.0);
                    // 1-9 in three rows, then Del, 0, OK.
                    let keys: Vec<(String, PadInput)> = ('1'..='9')
                        .map(|d| (d.to_string(), PadInput::Digit(d)))
                        .chain([
                            ("Del".to_string(), PadInput::Back),
                            ("0".to_string(), PadInput::Digit('0')),
                            ("OK".to_string(), PadInput::Enter),
                        ])
                        .collect();
                    egui::Grid::new("pin keys")
                        .spacing(egui::vec2(10.0, 10.0))
                        .show(ui, |ui| {
                            for row in keys.chunks(3) {
                                for (label, input) in row {
                                    let b = egui::Button::new(text(label, 28.0)).min_size(key);
                                    if ui.add(b).clicked() {
                                        pressed.push(*input);
                                    }
                                }
                                ui.end_row();
                            }
                        });
                    ui.add_space(8.0);
                    ui.vertical_centered(|ui| {
                        let b = egui::Button::new(text("Cancel", 22.0))
                            .min_size(egui::vec2(3.0 * key.x + 20.0, 56.0));
                        if ui.add(b).clicked() {
                            pressed.push(PadInput::Cancel);
                        }
                    });
                });
        });
    pressed
}

/// The staff panel: the kiosk's figures, its recent problems, and the way out. Only staff
/// open it (keys, or the corner held), so it may speak of milliseconds and errors.
fn staff_panel(ctx: &egui::Context, staff: &StaffView) -> (bool, bool) {
    let (mut close, mut quit) = (false, false);
    // As wide as the screen allows, long lines (a camera's error) wrapped.
    let width = (ctx.content_rect().width() - 40.0).clamp(200.0, 720.0);
    let text = |s: &str, size: f32| egui::RichText::new(s).size(size).color(LIGHT);
    egui::Area::new(egui::Id::unique("staff panel"))
        .anchor(egui::Align2::CENTER_TOP, egui::vec2(0.0, 64.0))
        .order(egui::Order::Foreground)
        .show(ctx, |ui| {
            egui::Frame::window(ui.style())
                .fill(egui::Color32::from_rgba_unmultiplied(16, 18, 22, 240))
                .inner_margin(egui::Margin::same(16))
                .show(ui, |ui| {
                    ui.set_width(width);
                    // Compact rows (the kiosk's finger-sized spacing is for its buttons).
                    ui.spacing_mut().interact_size.y = 20.0;
                    ui.spacing_mut().item_spacing = egui::vec2(8.0, 4.0);
                    ui.label(text("Staff", 24.0));
                    ui.add_space(6.0);
                    for (what, value) in &staff.rows {
                        ui.horizontal_wrapped(|ui| {
                            ui.label(text(what, 16.0).weak());
                            ui.label(text(value, 16.0).monospace());
                        });
                    }
                    ui.separator();
                    ui.label(text("Recent problems", 17.0));
                    if staff.log.is_empty() {
                        ui.label(text("none", 16.0).weak());
                    }
                    for line in &staff.log {
                        ui.add(egui::Label::new(text(line, 14.0).monospace()).wrap());
                    }
                    ui.separator();
                    ui.add(
                        egui::Label::new(
                            text(
                                "Ctrl+Shift+S or F12: this panel · Esc: close · Ctrl+Shift+Q: quit",
                                15.0,
                            )
                            .weak(),
                        )
                        .wrap(),
                    );
                    ui.horizontal(|ui| {
                        let big = egui::vec2(140.0, 56.0);
                        close = ui.add(egui::Button::new("Close").min_size(big)).clicked();
                        quit = ui
                            .add(egui::Button::new("Quit kiosk").min_size(big))
                            .clicked();
                    });
                });
        });
    (close, quit)
}

/// The attract mode's caption: two lines near the gem's foot, light on a dark band so that
/// they read over marble and agate alike.
fn caption(painter: &egui::Painter, rect: egui::Rect, title: &str, line: &str) {
    let font = |size| egui::FontId::proportional(size);
    let (title_size, line_size) = (
        (rect.width() / 12.0).clamp(28.0, 64.0),
        (rect.width() / 26.0).clamp(18.0, 32.0),
    );
    let width = rect.width() * 0.92;
    let title = painter.layout(
        title.to_owned(),
        font(title_size),
        egui::Color32::from_rgb(0xf6, 0xe7, 0xc1),
        width,
    );
    let line = painter.layout(
        line.to_owned(),
        font(line_size),
        egui::Color32::from_rgb(0xee, 0xee, 0xee),
        width,
    );
    let height = title.size().y + line.size().y + 28.0;
    let band = egui::Rect::from_min_size(
        egui::pos2(rect.left(), rect.bottom() - height - rect.height() * 0.04),
        egui::vec2(rect.width(), height),
    );
    painter.rect_filled(band, 0.0, egui::Color32::from_black_alpha(150));
    let y = band.top() + 10.0;
    painter.galley(
        egui::pos2(rect.center().x - title.size().x / 2.0, y),
        title.clone(),
        egui::Color32::WHITE,
    );
    painter.galley(
        egui::pos2(
            rect.center().x - line.size().x / 2.0,
            y + title.size().y + 8.0,
        ),
        line,
        egui::Color32::WHITE,
    );
}
