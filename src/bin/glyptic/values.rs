//! The command line's value parsers, shared by the commands (`cli`) and the kiosk: each
//! refuses a bad value when the command line is read (exit 2), naming the value and the rule.

/// `WxH` in pixels.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

/// Frame sizes accepted on the command line, pixels per side.
const SIZE_RANGE: std::ops::RangeInclusive<u32> = 16..=8192;

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (w, h) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<u32>()
                .map_err(|_| format!("`{v}` is not a whole number of pixels"))
        };
        let (width, height) = (parse(w)?, parse(h)?);
        if !SIZE_RANGE.contains(&width) || !SIZE_RANGE.contains(&height) {
            return Err(format!(
                "{width}x{height}: each side must be {}..={} pixels",
                SIZE_RANGE.start(),
                SIZE_RANGE.end()
            ));
        }
        let pixels = u64::from(width) * u64::from(height);
        if pixels > glyptic::render::MAX_PIXELS {
            return Err(format!(
                "{width}x{height}: {pixels} pixels, more than the renderer's {} (4096x4096)",
                glyptic::render::MAX_PIXELS
            ));
        }
        Ok(Size { width, height })
    }
}

/// A path option's parser for a file glyptic writes: its name must end in one of
/// `extensions` (any case), since what is written follows the option, not the name
/// (`--heightmap h.jpg` wrote PNG bytes under .jpg; issue #40). `what` names the format.
pub fn file_named(
    extensions: &'static [&'static str],
    what: &'static str,
) -> impl Fn(&str) -> Result<std::path::PathBuf, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        let path = std::path::PathBuf::from(s);
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if ext.is_some_and(|e| extensions.contains(&e.as_str())) {
            return Ok(path);
        }
        let names: Vec<String> = extensions.iter().map(|e| format!(".{e}")).collect();
        Err(format!(
            "{s}: this option writes {what}: name the file {}",
            names.join(" or ")
        ))
    }
}

/// A blur's tap count, checked by the renderer's own rule ([`glyptic::sss::SssParams::check_taps`])
/// when the command line is read.
pub fn odd_taps(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|e| format!("{s:?} is not a whole number ({e})"))?;
    glyptic::sss::SssParams::check_taps(n).map_err(|e| e.to_string())
}

/// A number option's parser: a finite value within `lo..=hi`, or an error that says the range
/// (NaN, infinities and out-of-range values never reach the work: `--style-time nan` used to
/// render a black gem).
pub fn finite_in<T>(
    lo: f64,
    hi: f64,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + Into<f64> + Copy + Send + Sync + 'static,
    T::Err: std::fmt::Display,
{
    move |s: &str| {
        let v: T = s
            .trim()
            .parse()
            .map_err(|e| format!("{s:?} is not a number ({e})"))?;
        let x: f64 = v.into();
        if x.is_finite() && (lo..=hi).contains(&x) {
            Ok(v)
        } else {
            Err(format!("{s}: must be a finite number in {lo}..={hi}"))
        }
    }
}

/// `-`: standard input for a photo, standard output for `photo`'s image.
pub fn is_stdio(path: &std::path::Path) -> bool {
    path.as_os_str() == "-"
}

/// [`file_named`], or `-` for standard output (the image as PNG).
#[cfg(feature = "face")]
pub fn file_named_or_stdout(
    extensions: &'static [&'static str],
    what: &'static str,
) -> impl Fn(&str) -> Result<std::path::PathBuf, String> + Clone + Send + Sync + 'static {
    let named = file_named(extensions, what);
    move |s: &str| {
        if s == "-" {
            Ok(std::path::PathBuf::from(s))
        } else {
            named(s)
        }
    }
}
