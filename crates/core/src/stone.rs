//! The stones a cameo is cut from, and its gold, described once: the renderer takes its
//! uniforms (the layered stones) and its shader constants (marble, gold) from here and the
//! glTF export its materials, so the two cannot drift apart.
//!
//! A layered stone is a ground layer under a white layer (and, in agate and shell, a darker
//! top layer the cutter uses for the hair): the carving cuts down through the white, so
//! where the relief is thin the ground shows through it. The colour at a point therefore
//! follows the relief's height above the ground (mm): `1 - exp(-height / veil_mm)` of the
//! white over the ground. Colours are display (sRGB) values with a gain applied before
//! decoding (agate's 2021 colours need it; the others use 1), as the shader does.
//!
//! The values come from photographs of catalogued pieces, described in `docs/stones.md`
//! (colours read there as sRGB, not copied from any picture).

/// The stone the gem is cut from: one type for the renderer, the GLB export, the kiosk's TOML (`"marble"`,
/// `"agate"`, `"shell"`, `"jasperware"`) and the command line (`--material`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Material {
    /// White statuary marble with a few quiet grey veins, polished (a faint, sharp highlight).
    #[default]
    Marble,
    /// Multilayer agate: red ground, white relief, brown hair (Phong, exponent 500).
    Agate,
    /// Shell: a cream figure on a salmon-orange ground that glows through the thin parts.
    Shell,
    /// Wedgwood's jasperware: a white relief on a pale blue ground, matte.
    Jasperware,
}

impl Material {
    /// Every stone, in the order the kiosk offers them.
    pub const ALL: [Material; 4] = [
        Material::Marble,
        Material::Agate,
        Material::Shell,
        Material::Jasperware,
    ];

    /// The stone's name as the command line and the TOML spell it.
    pub fn name(self) -> &'static str {
        match self {
            Material::Marble => "marble",
            Material::Agate => "agate",
            Material::Shell => "shell",
            Material::Jasperware => "jasperware",
        }
    }

    /// A layered stone's description (None: marble, one stone throughout).
    pub fn layers(self) -> Option<&'static Layers> {
        match self {
            Material::Marble => None,
            Material::Agate => Some(&AGATE),
            Material::Shell => Some(&SHELL),
            Material::Jasperware => Some(&JASPERWARE),
        }
    }
}

/// Statuary marble: a warm white, `MARBLE_GREY * MARBLE_TINT` (display values), veined by the
/// shader; its highlight's Blinn-Phong (n.h) exponent.
pub const MARBLE_GREY: f32 = 0.92;
pub const MARBLE_TINT: [f32; 3] = [1.0, 0.985, 0.955];
pub const MARBLE_BLINN: f32 = 90.0;
/// The setting's gold: reflectance at normal incidence (linear) and the highlight's
/// Blinn-Phong exponent.
pub const GOLD_F0: [f32; 3] = [1.0, 0.71, 0.29];
pub const GOLD_BLINN: f32 = 120.0;

/// One layered stone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layers {
    pub name: &'static str,
    /// The ground, the white (the figure) and the top layer (the hair; None: the stone has
    /// none, its hair stays white), display colours, each with the gain applied before
    /// decoding.
    pub ground: ([f32; 3], f32),
    pub white: ([f32; 3], f32),
    pub top: Option<([f32; 3], f32)>,
    /// White layer thickness (mm) that lets 1/e of the ground through.
    pub veil_mm: f32,
    /// Added where the white is thin (linear): agate's bluish veil, shell's warm glow.
    pub veil_tint: [f32; 3],
    /// The ground's mottling (noise amplitude), the shell's growth bands across the ground,
    /// and the white's fine grain.
    pub mottle: f32,
    pub bands: f32,
    pub grain: f32,
    /// The polish: the key highlight's Phong (r.l) exponent and strength, the studio's
    /// reflection (scaled by Fresnel), and how much light scatters under the surface (1: as
    /// the scattering pass's profile says; a dense ceramic less).
    pub phong: f32,
    pub highlight: f32,
    pub reflection: f32,
    pub scatter: f32,
}

/// Multilayer agate (sardonyx), the 2021 exhibit's colours: a dark red ground, a cool white
/// figure whose thin edges show a bluish veil, a brown top layer; a glass-hard polish.
pub const AGATE: Layers = Layers {
    name: "agate",
    ground: ([0.0745, 0.0196, 0.0196], 4.0),
    white: ([0.6706, 0.6902, 0.6706], 1.2),
    top: Some(([0.2863, 0.1137, 0.0078], 1.25)),
    veil_mm: 0.45,
    veil_tint: [0.02, 0.035, 0.07],
    mottle: 0.3,
    bands: 0.0,
    grain: 0.03,
    phong: 500.0,
    highlight: 0.9,
    reflection: 0.5,
    scatter: 1.0,
};

/// Shell (the helmet shell, Cassis, the commonest cameo since the 19th century): a cream
/// figure on a salmon-orange ground that glows warm through the thin parts, faint growth
/// bands across the ground, the hair often left in the browner layer; a softer polish, and
/// less scattering than marble (the layers are dense; thin parts glow by their colour).
pub const SHELL: Layers = Layers {
    name: "shell",
    ground: ([0.72, 0.42, 0.29], 1.0),
    white: ([0.95, 0.91, 0.85], 1.0),
    top: Some(([0.56, 0.31, 0.19], 1.0)),
    veil_mm: 0.7,
    veil_tint: [0.05, 0.018, 0.0],
    mottle: 0.12,
    bands: 0.06,
    grain: 0.03,
    phong: 60.0,
    highlight: 0.3,
    reflection: 0.35,
    scatter: 0.6,
};

/// Jasperware (Wedgwood's unglazed stoneware, 1775 on): a pale blue ground with the white
/// relief applied on it, so the white stays white down to a thin edge; matte, and dense (it
/// scatters little light).
pub const JASPERWARE: Layers = Layers {
    name: "jasperware",
    ground: ([0.47, 0.6, 0.75], 1.0),
    white: ([0.94, 0.94, 0.91], 1.0),
    top: None,
    veil_mm: 0.15,
    veil_tint: [0.0, 0.0, 0.0],
    mottle: 0.04,
    bands: 0.0,
    grain: 0.04,
    phong: 8.0,
    highlight: 0.04,
    reflection: 0.05,
    scatter: 0.3,
};

/// The display-to-linear decoding (sRGB), as the shader's `srgb_to_linear`.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A display colour with its gain, decoded to linear.
pub fn linear((display, gain): ([f32; 3], f32)) -> [f32; 3] {
    display.map(|c| srgb_to_linear(c * gain))
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Layers {
    /// The colour (linear) at a point `relief` mm above the ground with hair weight `hair`:
    /// the shader's `layered_albedo` without its noise (whose means it keeps).
    pub fn colour(&self, relief: f32, hair: f32, hair_layer: bool) -> [f32; 3] {
        let ground = linear(self.ground);
        let white = linear(self.white).map(|c| (1.0 - self.grain) * c);
        let w = 1.0 - (-relief.max(0.0) / self.veil_mm).exp();
        let mut col: [f32; 3] = std::array::from_fn(|k| {
            ground[k] + (white[k] - ground[k]) * w + 4.0 * w * (1.0 - w) * self.veil_tint[k]
        });
        if let (true, Some(top)) = (hair_layer, self.top) {
            // The top layer's noise (0.75 + 0.4 * strands) averages 0.75.
            let top = linear(top).map(|c| 0.75 * c);
            let h = smoothstep(0.15, 0.85, hair.clamp(0.0, 1.0)) * smoothstep(0.6, 1.8, relief);
            col = std::array::from_fn(|k| col[k] + (top[k] - col[k]) * h);
        }
        col.map(|c| c.clamp(0.0, 1.0))
    }

    /// The renderer's uniforms for this stone (`Frame.layers` in `scene.wgsl`): ground, white
    /// and top colours (linear; a stone without a top layer repeats its white) with the
    /// mottling, the veil's thickness and the bands in their fourth places; the veil's tint
    /// and the grain; the polish.
    pub fn uniforms(&self) -> [[f32; 4]; 5] {
        let [g, w, t] = [self.ground, self.white, self.top.unwrap_or(self.white)].map(linear);
        let v = self.veil_tint;
        [
            [g[0], g[1], g[2], self.mottle],
            [w[0], w[1], w[2], self.veil_mm],
            [t[0], t[1], t[2], self.bands],
            [v[0], v[1], v[2], self.grain],
            [self.phong, self.highlight, self.reflection, self.scatter],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn luma(c: [f32; 3]) -> f32 {
        0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    }

    #[test]
    fn every_stone_is_a_light_figure_on_a_darker_ground() {
        for s in [AGATE, SHELL, JASPERWARE] {
            let ground = s.colour(0.0, 0.0, true);
            let thin = s.colour(0.2, 0.0, true);
            let figure = s.colour(4.0, 0.0, true);
            assert!(
                luma(figure) > 1.5 * luma(ground),
                "{}: figure {figure:?}, ground {ground:?}",
                s.name
            );
            // A thin edge lies between the two.
            assert!(
                luma(thin) > luma(ground) && luma(thin) < luma(figure),
                "{}",
                s.name
            );
        }
    }

    #[test]
    fn the_stones_are_told_apart_by_their_grounds() {
        let hue = |c: [f32; 3]| {
            let [r, g, b] = c;
            (r - b, g - b)
        };
        let [a, s, j] = [AGATE, SHELL, JASPERWARE].map(|l| hue(l.colour(0.0, 0.0, false)));
        // Agate's ground is red (its red well above its green), shell's orange (green between
        // red and blue), jasperware's blue (blue above red).
        assert!(a.0 > 2.0 * a.1, "agate {a:?}");
        assert!(s.0 > 0.1 && s.1 > 0.02 && s.1 < s.0, "shell {s:?}");
        assert!(j.0 < 0.0, "jasperware {j:?}");
    }

    #[test]
    fn shell_glows_warmer_at_its_thin_parts_than_jasperware() {
        // At a third of a millimetre the shell's ground shows (warm), jasperware's white
        // already covers it.
        let warmth = |c: [f32; 3]| c[0] - c[2];
        let shell = SHELL.colour(0.35, 0.0, false);
        let jasper = JASPERWARE.colour(0.35, 0.0, false);
        assert!(warmth(shell) > 0.15, "{shell:?}");
        let covered = 1.0 - (-0.35f32 / JASPERWARE.veil_mm).exp();
        assert!(covered > 0.9 && warmth(jasper) < 0.05, "{jasper:?}");
    }

    #[test]
    fn the_hair_takes_the_top_layer_only_with_it() {
        let hair = AGATE.colour(4.0, 1.0, true);
        let white = AGATE.colour(4.0, 1.0, false);
        assert!(luma(hair) < 0.5 * luma(white));
        // Jasperware has no third layer: the hair stays white.
        let j = JASPERWARE.colour(4.0, 1.0, true);
        assert!((luma(j) - luma(JASPERWARE.colour(4.0, 0.0, true))).abs() < 0.05);
    }
}
