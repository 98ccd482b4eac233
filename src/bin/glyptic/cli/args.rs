//! The argument groups several commands share: how the gem is shown (`ViewArgs`, with the
//! scattering's `SssArgs`), whose face and what of the photo goes into it (`ChoiceArgs`), and
//! frame sizes. The types they choose among are the library's own (clap derives on them).

use anyhow::{Context, Result};
use clap::ValueEnum;

use crate::values::{Size, finite_in, odd_taps};
use glyptic::gem;
use glyptic::render::{Material, RenderParams};

/// How the gem is shown.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// Stone of the cameo.
    #[arg(long, value_enum, default_value_t = Material::Marble)]
    pub material: Material,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "640x800")]
    pub size: Size,
    /// Orbit the view around the gem, degrees (0 looks straight at it), -360..=360.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true,
          value_parser = finite_in::<f32>(-360.0, 360.0))]
    pub yaw: f32,
    /// Tilt the view, degrees, -89..=89 (at 90 the gem is seen edge-on).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true,
          value_parser = finite_in::<f32>(-glyptic::render::MAX_PITCH_DEG as f64,
                                          glyptic::render::MAX_PITCH_DEG as f64))]
    pub pitch: f32,
    /// How the portrait is carved: facing the viewer (the default: a face-recognition network,
    /// and a friend, know the sitter best this way; BENCHMARKS.md, issue #37) or in profile
    /// (the classic cameo).
    #[arg(long, value_enum, default_value_t = gem::View::Frontal)]
    pub portrait: gem::View,
    /// The gold round the stone: a plain bezel, a milgrain collet (its rim a row of beads) or
    /// the bezel framed by a rope of two twisted wires.
    #[arg(long, value_enum, default_value_t = gem::Setting::Plain)]
    pub setting: gem::Setting,
    /// A ring on the setting's top for wearing the cameo as a pendant.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub bail: OnOff,
    #[command(flatten)]
    pub sss: SssArgs,
    /// Gallery styles after the render, in order: toon, dither, painterly, fisheye, chromatic
    /// (e.g. `--style toon,fisheye`).
    #[arg(long, value_name = "NAME[,NAME...]")]
    pub style: Option<StyleChain>,
    /// The moment (seconds) the moving styles (chromatic) show.
    #[arg(long, default_value_t = 0.0, value_name = "S", allow_negative_numbers = true,
          value_parser = finite_in::<f32>(0.0, 1e6))]
    pub style_time: f32,
    /// An engraved Greek-key border round the ground (parallax occlusion mapping).
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub engraving: OnOff,
    /// A raking lamp at the upper left whose shadows the relief casts on the ground.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub lamp: OnOff,
    /// Agate: cut the hair from a third, brown layer (off: white like the face).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub hair_layer: OnOff,
    /// The backdrop: the studio's (a soft gradient) or none (a PNG whose alpha is the gem's
    /// outline, for putting it onto something else).
    #[arg(long, value_enum, default_value_t = Backdrop::Studio)]
    pub background: Backdrop,
    /// 4x multisampling (off: one sample a pixel and an edge-smoothing pass, about 1.8 times
    /// faster on a CPU rasteriser, with a slightly softer bezel rim).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub antialias: OnOff,
}

/// `--style`'s list.
#[derive(Clone, Debug)]
pub struct StyleChain(pub Vec<glyptic::styles::Style>);

impl std::str::FromStr for StyleChain {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        glyptic::styles::Style::parse_chain(s).map(StyleChain)
    }
}

/// Subsurface scattering options (`render`, `photo`, `batch`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct SssArgs {
    /// Subsurface scattering: light diffusing through the stone.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub sss: OnOff,
    /// Blur taps per direction (odd, 3..=65).
    #[arg(long, default_value_t = 21, value_name = "N", value_parser = odd_taps)]
    pub sss_taps: usize,
    /// How much light scatters, 0..=1 (red's share; green and blue follow the reference balance).
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_STRENGTH, value_name = "S",
          allow_negative_numbers = true, value_parser = finite_in::<f32>(0.0, 1.0))]
    pub sss_strength: f32,
    /// How far light travels under the surface, mm (the kernel's reach).
    #[arg(long, default_value_t = glyptic::sss::DEFAULT_WIDTH_MM, value_name = "MM",
          allow_negative_numbers = true, value_parser = finite_in::<f32>(0.0, 20.0))]
    pub sss_width: f32,
    /// Diffusion profile.
    #[arg(long, value_enum, default_value_t = glyptic::sss::Profile::Marble)]
    pub sss_profile: glyptic::sss::Profile,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backdrop {
    Studio,
    Transparent,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

impl SssArgs {
    /// The kernel parameters (even with `--sss off`, for `glyptic kernel`), validated.
    pub(super) fn params(&self) -> Result<glyptic::sss::SssParams> {
        let p = glyptic::sss::SssParams {
            taps: self.sss_taps,
            strength: glyptic::sss::SssParams::strength_rgb(self.sss_strength),
            width_mm: self.sss_width,
            profile: self.sss_profile,
            falloff: self.sss_profile.falloff(),
        };
        p.validate().context("subsurface scattering")?;
        Ok(p)
    }
}

impl ViewArgs {
    /// The cameo: the portrait's view in the chosen setting.
    pub fn cameo(&self) -> gem::CameoParams {
        gem::CameoParams {
            setting: self.setting,
            bail: self.bail == OnOff::On,
            ..self.portrait.cameo()
        }
    }

    pub(super) fn params(&self) -> Result<RenderParams> {
        Ok(RenderParams {
            width: self.size.width,
            height: self.size.height,
            material: self.material,
            yaw_deg: self.yaw,
            pitch_deg: self.pitch,
            sss: match self.sss.sss {
                OnOff::On => Some(self.sss.params()?),
                OnOff::Off => None,
            },
            styles: self.style.clone().map_or_else(Vec::new, |c| c.0),
            style_time_s: self.style_time,
            engraving: (self.engraving == OnOff::On)
                .then(glyptic::render::surface::EngravingParams::default),
            lamp: (self.lamp == OnOff::On).then(glyptic::render::Lamp::default),
            hair_layer: self.hair_layer == OnOff::On,
            antialias: self.antialias == OnOff::On,
            transparent: self.background == Backdrop::Transparent,
            ..RenderParams::default()
        })
    }
}

#[cfg(feature = "face")]
/// Which face is the subject when a photo or frame holds several, and what of the photo
/// besides the face goes into the gem.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ChoiceArgs {
    /// The subject among several faces: the largest, or the one nearest the image's centre
    /// (a kiosk with people passing behind the visitor).
    #[arg(long, value_enum, default_value_t = glyptic::detect::FaceChoice::Largest)]
    pub prefer: glyptic::detect::FaceChoice,
    /// The hair: the person's own, as the photo shows it (bald stays bald, long hair falls
    /// over the shoulders), or the same classical hairstyle for everyone.
    #[arg(long, value_enum, default_value_t = glyptic::pipeline::Hair::Photo)]
    pub hair: glyptic::pipeline::Hair,
    /// The portrait's caricature, GAIN,DETAIL: the gain multiplies the face's difference from
    /// the mean face, the detail (0..1) exaggerates its small, telling differences more than
    /// its large ones. `1,0` carves the fitted face as it is.
    #[arg(long, value_parser = parse_caricature, default_value = "1,0.5")]
    pub caricature: glyptic::shapemodel::Caricature,
    /// How much of the photo's expression the portrait carves: 0 a calm, neutral face (as
    /// classical cameos have), 1 all of it.
    #[arg(long, value_parser = parse_expression, default_value = "0.5")]
    pub expression: f32,
    /// Glasses found on the photo: carved as a cutter would (the rims and temples as ridges on
    /// the face), or left out.
    #[arg(long, value_enum, default_value_t = GlassesArg::Carve)]
    pub glasses: GlassesArg,
    /// How strongly the photo's own detail is carved into the face (the brows raised, the
    /// irises drilled, the mouth's line and the face's folds cut; in a frontal portrait the
    /// photo's fine light and dark modelled for the stone's light), 0..3: 0 carves the fitted
    /// shape alone, 1 as a cutter would.
    #[arg(long, value_parser = parse_detail, default_value = "1")]
    pub detail: f32,
    /// How deep the photo's darks are stippled into a frontal face (part of the detail): round
    /// pits about 0.3 mm apart, each as wide as the photo is dark there, as a stipple engraver
    /// renders tone, 0..3: 0 leaves the skin smooth (the relief's grid stays at 0.2 mm; on a
    /// CPU the photo is then about a tenth faster), 1 as measured (BENCHMARKS.md, issue #37).
    #[arg(long, value_parser = parse_stipple, default_value = "1")]
    pub stipple: f32,
    /// How deep the photo's dark lines are engraved into a frontal face (part of the detail):
    /// the lash line, the lid's crease, the lips' line and the folds, each a narrow groove
    /// along the photo's brightness valley, as an engraver cuts a line where dots cannot,
    /// 0..3: 0 leaves the lines to the stipple and the slopes, 1 as measured (BENCHMARKS.md,
    /// issue #37, seventeenth session).
    #[arg(long, value_parser = parse_engraved_lines, default_value = "1")]
    pub engraved_lines: f32,
    /// How much of the photo's strongest darks in a frontal face (part of the detail) is cut
    /// into the shadow the key light casts, 0..1: the stone there sunk under the shadow's line
    /// (the eye's corners and lashes, a nostril, the lips' line, glasses' rims), as a carver
    /// deepens a socket under its brow; 0 leaves them to the modelled slopes and the stipple.
    #[arg(long, value_parser = parse_shadows, default_value = "1")]
    pub shadows: f32,
    /// How much of a frontal face's fine modelling (its forms finer than about a sixth of the
    /// eyes' distance: the nose's sides, the sockets, the lips' edges) is the photo's light
    /// and dark rather than the fitted shape's, 0..1: the shape's own shade much alike on
    /// every gem; 1 as measured (BENCHMARKS.md, issue #37, fourteenth session), 0 both added.
    #[arg(long, value_parser = parse_photo_modelling, default_value = "1")]
    pub photo_modelling: f32,
    /// How a frontal face's carved light and dark is matched to the photo's as the stone's
    /// own light shows it (part of the detail), 0..3: after the tone, the stipple and the
    /// shadows are cut, the relief is lit as the renderer lights it and its slopes along the
    /// key light corrected where its light differs from the photo's; the value is the
    /// contrast asked for against the one the carving shows (1 the same, 1.5 as measured:
    /// BENCHMARKS.md, issue #37, sixteenth session); 0 carves without the match.
    #[arg(long, value_parser = parse_tone_match, default_value = "1.5")]
    pub tone_match: f32,
    /// How many faces the likeness search draws and judges with the face-recognition network
    /// (the portrait's identity steered towards the photo, within the face model's prior);
    /// 0 (the default) keeps the landmark fit's identity: on the whole gem the search no
    /// longer brings the gems nearer their people (BENCHMARKS.md, issue #37, measured twice).
    /// About 13 ms a face on two CPU cores plus the network's start (11 faces: about 270 ms).
    #[arg(long, value_name = "FACES", default_value_t = 0,
          value_parser = clap::value_parser!(u32).range(0..=2000))]
    pub likeness_search: u32,
    /// How strongly the face's shape read from the photo's shading is carved (the cheeks,
    /// the eyes' sockets, the folds the 68 landmarks cannot see), 0..3: 0 carves the face
    /// model's shape alone, 1 as the shading says. About 20 ms.
    #[arg(long, value_parser = parse_shading, default_value = "1")]
    pub shading: f32,
    /// How far the face follows the photo's landmarks where the face model cannot (the eyes'
    /// and brows' own shape, the jaw's outline, the mouth's width), 0..3: 0 carves the face
    /// model's fit alone, 1 brings its landmarks onto the photo's. Under a millisecond.
    #[arg(long, value_parser = parse_warp, default_value = "1")]
    pub warp: f32,
}

#[cfg(feature = "face")]
fn parse_detail(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "detail")
}

#[cfg(feature = "face")]
fn parse_stipple(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "stipple")
}

#[cfg(feature = "face")]
fn parse_engraved_lines(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "engraved lines")
}

#[cfg(feature = "face")]
fn parse_shadows(s: &str) -> Result<f32, String> {
    strength_up_to(s, "shadow", 1.0)
}

#[cfg(feature = "face")]
fn parse_photo_modelling(s: &str) -> Result<f32, String> {
    strength_up_to(s, "photo modelling", 1.0)
}

#[cfg(feature = "face")]
fn parse_tone_match(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "tone match")
}

#[cfg(feature = "face")]
fn parse_shading(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "shading")
}

#[cfg(feature = "face")]
fn parse_warp(s: &str) -> Result<f32, String> {
    strength_0_to_3(s, "warp")
}

/// A strength of 0..3 (0: off, 1: as read), named in the error.
#[cfg(feature = "face")]
fn strength_0_to_3(s: &str, what: &str) -> Result<f32, String> {
    strength_up_to(s, what, 3.0)
}

/// A strength of 0..`most`, named in the error.
#[cfg(feature = "face")]
fn strength_up_to(s: &str, what: &str, most: f32) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if (0.0..=most).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v}: the {what}'s strength must be 0..{most}")),
        Err(e) => Err(format!("{s:?} is not a number ({e})")),
    }
}

#[cfg(feature = "face")]
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GlassesArg {
    Carve,
    Leave,
}

#[cfg(feature = "face")]
fn parse_expression(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v}: the expression's share must be 0..1")),
        Err(e) => Err(format!("{s:?} is not a number ({e})")),
    }
}

#[cfg(feature = "face")]
fn parse_caricature(s: &str) -> Result<glyptic::shapemodel::Caricature, String> {
    let (g, d) = s
        .split_once(',')
        .ok_or_else(|| format!("{s}: expected GAIN,DETAIL, e.g. 1,0.5"))?;
    let number = |v: &str| {
        v.trim()
            .parse::<f32>()
            .map_err(|e| format!("{s}: {v:?} is not a number ({e})"))
    };
    let c = glyptic::shapemodel::Caricature {
        gain: number(g)?,
        detail: number(d)?,
    };
    if c.is_valid() {
        Ok(c)
    } else {
        Err(format!("{s}: the gain must be 0..4 and the detail 0..1"))
    }
}

#[cfg(feature = "face")]
impl ChoiceArgs {
    pub fn apply(&self, options: &mut glyptic::detect::DetectOptions) {
        options.prefer = self.prefer;
    }

    /// The subject's choice, the portrait's caricature and its share of the expression.
    pub fn apply_face(&self, pipeline: &mut glyptic::pipeline::FacePipeline) {
        self.apply(&mut pipeline.faces.detect_options);
        pipeline.caricature = self.caricature;
        pipeline.portrait_expression = self.expression;
    }

    /// The photo -> gem pipeline with these choices and `view`'s portrait, its detector on
    /// `detector_threads` threads.
    pub fn gem_pipeline(
        &self,
        view: &ViewArgs,
        detector_threads: usize,
    ) -> Result<glyptic::pipeline::GemPipeline> {
        let mut p = glyptic::pipeline::GemPipeline::load_with(
            &glyptic::assets::ModelPaths::locate(),
            view.cameo(),
            self.hair,
            glyptic::pipeline::LoadOptions {
                recognise: self.likeness_search > 0,
                detector_threads,
            },
        )?;
        self.apply_face(&mut p.face);
        p.carve_glasses = self.glasses == GlassesArg::Carve;
        p.detail = (self.detail > 0.0).then(|| {
            glyptic::gem::DetailParams::default()
                .scaled(self.detail)
                .stipple_scaled(self.stipple)
                .engraved_lines_scaled(self.engraved_lines)
                .with_shadows(self.shadows)
                .with_photo_modelling(self.photo_modelling)
                .with_tone_match(self.tone_match)
        });
        p.shading = (self.shading > 0.0).then(|| glyptic::photometric::ShadingParams {
            strength: self.shading,
            ..Default::default()
        });
        p.warp = (self.warp > 0.0).then(|| glyptic::warp::WarpParams {
            strength: self.warp,
            ..Default::default()
        });
        if self.likeness_search > 0 {
            p.identity =
                glyptic::identity::SearchOptions::with_faces(self.likeness_search as usize);
        }
        Ok(p)
    }
}
