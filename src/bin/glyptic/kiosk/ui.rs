//! The kiosk's controls (egui): finger-sized, three rows under the gem, drags on the gem orbit
//! it. Each control's rectangle is kept for scripted runs (`--trace`).

use glyptic::kiosk::{Controls, Orbit};
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

/// One frame of the controls.
/// A button that shows `on` as selected and flips it when pressed; `label` says the state.
fn toggle(ui: &mut egui::Ui, on: &mut bool, label: &str) -> egui::Response {
    let r = ui.add(egui::Button::selectable(*on, label));
    if r.clicked() {
        *on = !*on;
    }
    r
}

pub(super) struct UiFrame<'a> {
    pub(super) controls: &'a mut Controls,
    pub(super) orbit: &'a mut Orbit,
    pub(super) layer: Option<egui::TextureId>,
    pub(super) status: String,
    pub(super) toast: Option<String>,
    /// Where the gem is shown (points).
    pub(super) gem_rect: Option<egui::Rect>,
    pub(super) snapshot: bool,
    /// Where each control is (points), for scripted runs.
    pub(super) rects: Vec<(&'static str, egui::Rect)>,
}

impl UiFrame<'_> {
    pub(super) fn draw(&mut self, root: &mut egui::Ui) {
        egui::Panel::top("status").show(root, |ui| {
            ui.add(egui::Label::new(egui::RichText::new(&self.status).size(18.0)).truncate());
        });
        egui::Panel::bottom("controls").show(root, |ui| {
            ui.add_space(6.0);
            // Three rows: the stone, the glow, the portrait.
            ui.horizontal(|ui| {
                for (material, name, key) in [
                    (Material::Marble, "Marble", "marble"),
                    (Material::Agate, "Agate", "agate"),
                ] {
                    let on = self.controls.material == material;
                    let r = ui.add(egui::Button::selectable(on, name));
                    if r.clicked() {
                        self.controls.material = material;
                    }
                    self.rects.push((key, r.rect));
                }
                ui.separator();
                let label = self.controls.sss_label();
                let r = toggle(ui, &mut self.controls.sss, label);
                self.rects.push(("sss", r.rect));
            });
            ui.horizontal(|ui| {
                // The slider takes the row but the reset button's room.
                ui.spacing_mut().slider_width = (ui.available_width() - 130.0).clamp(120.0, 600.0);
                let r = ui.add_enabled(
                    self.controls.sss,
                    egui::Slider::new(&mut self.controls.sss_strength, 0.0..=1.0).show_value(false),
                );
                self.rects.push(("strength", r.rect));
                let r = ui.button("Reset");
                if r.clicked() {
                    self.controls.reset_strength();
                }
                self.rects.push(("reset", r.rect));
            });
            ui.horizontal(|ui| {
                let label = self.controls.freeze_label();
                let r = toggle(ui, &mut self.controls.frozen, label);
                self.rects.push(("freeze", r.rect));
                let r = ui.button("Save picture");
                if r.clicked() {
                    self.snapshot = true;
                }
                self.rects.push(("save", r.rect));
                let r = ui.button("Front view");
                if r.clicked() {
                    *self.orbit = Orbit::default();
                }
                self.rects.push(("front", r.rect));
            });
            ui.horizontal(|ui| {
                let r = ui.add(egui::Button::selectable(
                    self.controls.style.is_some(),
                    self.controls.style_label(),
                ));
                if r.clicked() {
                    self.controls.next_style();
                }
                self.rects.push(("style", r.rect));
                let label = self.controls.engraving_label();
                let r = toggle(ui, &mut self.controls.engraving, label);
                self.rects.push(("border", r.rect));
                let label = self.controls.lamp_label();
                let r = toggle(ui, &mut self.controls.lamp, label);
                self.rects.push(("lamp", r.rect));
            });
            if let Some(t) = &self.toast {
                ui.label(t);
            }
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
    }
}
