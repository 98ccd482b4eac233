//! Landmark files: iBUG `.pts` and menpo's `.ljson`.
//!
//! All functions here use glyptic's convention: points are `[x, y]` in 0-based image pixels
//! (pixel centres at integers). `.pts` files store 1-based `x y` (they come from Matlab);
//! like menpo we subtract 1 on reading and add 1 on writing. `.ljson` stores 0-based
//! `[y, x]` (menpo's axis order); we swap.

use super::LandmarkError;

/// Parses an iBUG `.pts` file:
///
/// ```text
/// version: 1
/// n_points:  68
/// {
/// 357.417253 308.455774
/// ...
/// }
/// ```
///
/// Header lines before `{` are `key: value`; `n_points`, when present, must match the
/// number of points. Returns 0-based `[x, y]`. Every coordinate must be a finite number.
pub fn read_pts(text: &str) -> Result<Vec<[f32; 2]>, LandmarkError> {
    parse_pts(text, false)
}

/// [`read_pts`] for landmark sets with gaps: a point written `nan nan` is a landmark that was
/// not found (hidden, or dropped by a detector) and comes back as `[NaN, NaN]`, which the
/// fitter leaves out. Infinities, and a NaN in only one coordinate, are still errors.
pub fn read_pts_with_missing(text: &str) -> Result<Vec<[f32; 2]>, LandmarkError> {
    parse_pts(text, true)
}

fn parse_pts(text: &str, allow_missing: bool) -> Result<Vec<[f32; 2]>, LandmarkError> {
    // A byte-order mark (Windows editors) and old Mac line ends are still a .pts file.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let normalized;
    let text = if text.contains('\r') {
        normalized = text.replace("\r\n", "\n").replace('\r', "\n");
        normalized.as_str()
    } else {
        text
    };
    let err = |line: usize, problem: String| LandmarkError::Parse {
        format: "pts",
        line,
        problem,
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let mut declared: Option<usize> = None;
    // Header.
    loop {
        let Some((no, line)) = lines.next() else {
            let problem = if text.trim().is_empty() {
                "the file is empty".into()
            } else {
                "no '{' opening the point list".into()
            };
            return Err(err(text.lines().count().max(1), problem));
        };
        if line.is_empty() {
            continue;
        }
        if line == "{" {
            break;
        }
        let Some((key, value)) = line.split_once(':') else {
            return Err(err(
                no,
                format!("expected 'key: value' or '{{', found {}", excerpt(line)),
            ));
        };
        if key.trim() == "n_points" {
            let n = value
                .trim()
                .parse::<usize>()
                .map_err(|e| err(no, format!("n_points {}: {e}", excerpt(value.trim()))))?;
            declared = Some(n);
        }
    }
    // Points.
    let mut points = Vec::with_capacity(declared.unwrap_or(0).min(text.len() / 4 + 1));
    let mut closed = false;
    for (no, line) in lines.by_ref() {
        if line.is_empty() {
            continue;
        }
        if line == "}" {
            closed = true;
            break;
        }
        let mut fields = line.split_whitespace();
        let (Some(xs), Some(ys), None) = (fields.next(), fields.next(), fields.next()) else {
            return Err(err(
                no,
                format!("expected two numbers 'x y', found {}", excerpt(line)),
            ));
        };
        let is_nan = |s: &str| s.eq_ignore_ascii_case("nan");
        if allow_missing && is_nan(xs) && is_nan(ys) {
            points.push([f32::NAN, f32::NAN]);
            continue;
        }
        let parse = |s: &str| -> Result<f32, LandmarkError> {
            match s.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(v) => Err(err(no, format!("non-finite coordinate {v}"))),
                Err(e) => Err(err(no, format!("coordinate {}: {e}", excerpt(s)))),
            }
        };
        points.push([parse(xs)? - 1.0, parse(ys)? - 1.0]);
    }
    if !closed {
        return Err(err(
            text.lines().count(),
            "no '}' closing the point list".into(),
        ));
    }
    if let Some((no, line)) = lines.find(|(_, l)| !l.is_empty()) {
        return Err(err(
            no,
            format!("unexpected text after '}}': {}", excerpt(line)),
        ));
    }
    if let Some(n) = declared
        && n != points.len()
    {
        return Err(err(
            0,
            format!(
                "header says n_points: {n}, but {} points follow",
                points.len()
            ),
        ));
    }
    Ok(points)
}

/// Writes an iBUG `.pts` file (1-based `x y`, menpo's header). Six decimals, like the
/// iBUG annotations themselves, so a round trip is exact to 1e-6 pixel.
pub fn write_pts(points: &[[f32; 2]]) -> String {
    let mut s = format!("version: 1\nn_points: {}\n{{\n", points.len());
    for p in points {
        s.push_str(&format!(
            "{:.6} {:.6}\n",
            f64::from(p[0]) + 1.0,
            f64::from(p[1]) + 1.0
        ));
    }
    s.push_str("}\n");
    s
}

/// Reads the points of a menpo `.ljson` file (versions 1, 2 and 3), as 0-based `[x, y]`.
///
/// Version 3 holds several named groups; this takes the group named `LJSON` (menpo's name
/// for the file's own annotation) if there is one, otherwise the group with the most
/// points. Use [`read_ljson_group`] to pick another. A missing (`null`) point is an error.
pub fn read_ljson(text: &str) -> Result<Vec<[f32; 2]>, LandmarkError> {
    read_ljson_group(text, None)
}

/// [`read_ljson`] for a named group of a version-3 file (`None`: the default choice).
pub fn read_ljson_group(text: &str, group: Option<&str>) -> Result<Vec<[f32; 2]>, LandmarkError> {
    use serde_json::Value;
    let err = |problem: String| LandmarkError::Parse {
        format: "ljson",
        line: 0,
        problem,
    };
    let doc: Value = serde_json::from_str(text).map_err(|e| LandmarkError::Parse {
        format: "ljson",
        line: e.line(),
        problem: e.to_string(),
    })?;
    let version = doc.get("version").and_then(Value::as_u64).unwrap_or(1);
    match version {
        3 => {
            let groups = doc
                .get("groups")
                .and_then(Value::as_object)
                .ok_or_else(|| err("version 3 without a 'groups' object".into()))?;
            let chosen = match group {
                Some(name) => groups
                    .get(name)
                    .ok_or_else(|| err(format!("no group named {name:?}")))?,
                None => match groups.get("LJSON") {
                    Some(g) => g,
                    None => groups
                        .values()
                        .max_by_key(|g| {
                            g.pointer("/landmarks/points")
                                .and_then(Value::as_array)
                                .map_or(0, Vec::len)
                        })
                        .ok_or_else(|| err("no groups".into()))?,
                },
            };
            let points = chosen
                .pointer("/landmarks/points")
                .ok_or_else(|| err("group without 'landmarks.points'".into()))?;
            yx_points(points)
        }
        2 => {
            let points = doc
                .pointer("/landmarks/points")
                .ok_or_else(|| err("version 2 without 'landmarks.points'".into()))?;
            yx_points(points)
        }
        1 => {
            // {"groups": [{"label": .., "landmarks": [{"point": [y, x]}, ..]}, ..]}
            let groups = doc
                .get("groups")
                .and_then(Value::as_array)
                .ok_or_else(|| err("version 1 without a 'groups' list".into()))?;
            let mut out = Vec::new();
            for g in groups {
                let lms = g
                    .get("landmarks")
                    .and_then(Value::as_array)
                    .ok_or_else(|| err("group without a 'landmarks' list".into()))?;
                for lm in lms {
                    let p = lm
                        .get("point")
                        .ok_or_else(|| err("landmark without 'point'".into()))?;
                    out.push(yx_point(p, out.len())?);
                }
            }
            Ok(out)
        }
        v => Err(err(format!("unsupported ljson version {v}"))),
    }
}

fn yx_points(points: &serde_json::Value) -> Result<Vec<[f32; 2]>, LandmarkError> {
    let list = points.as_array().ok_or_else(|| LandmarkError::Parse {
        format: "ljson",
        line: 0,
        problem: "'points' is not a list".into(),
    })?;
    list.iter()
        .enumerate()
        .map(|(i, p)| yx_point(p, i))
        .collect()
}

fn yx_point(p: &serde_json::Value, index: usize) -> Result<[f32; 2], LandmarkError> {
    let coords = p
        .as_array()
        .map(|a| a.iter().map(serde_json::Value::as_f64).collect::<Vec<_>>());
    match coords.as_deref() {
        Some([Some(y), Some(x)]) if x.is_finite() && y.is_finite() => Ok([*x as f32, *y as f32]),
        _ => Err(LandmarkError::Parse {
            format: "ljson",
            line: 0,
            problem: format!("point {index} is not two finite numbers [y, x]: {p}"),
        }),
    }
}

/// A line of a file as an error quotes it: whole when short, else its start and its length
/// (a 5 MB line must not become a 5 MB message).
pub fn excerpt(line: &str) -> String {
    const MAX: usize = 60;
    match line.char_indices().nth(MAX) {
        None => format!("{line:?}"),
        Some((cut, _)) => format!("{:?}... ({} bytes)", &line[..cut], line.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A byte-order mark, CRLF and CR-only line ends read as the plain file does; a huge bad
    /// line is quoted by its start and length (issue #19).
    #[test]
    fn bom_old_line_ends_and_long_lines() {
        let plain = "version: 1\nn_points: 2\n{\n1 2\n3 4\n}\n";
        let want = read_pts(plain).unwrap();
        for text in [
            format!("\u{feff}{plain}"),
            plain.replace('\n', "\r\n"),
            plain.replace('\n', "\r"),
        ] {
            assert_eq!(read_pts(&text).unwrap(), want, "{text:?}");
        }
        let long = format!("n_points: 1\n{{\n{}\n}}\n", "a".repeat(5_000_000) + " 1");
        let msg = read_pts(&long).unwrap_err().to_string();
        assert!(
            msg.len() < 300 && msg.contains("5000000 bytes"),
            "{}",
            &msg[..300.min(msg.len())]
        );
    }

    #[test]
    fn missing_points_only_where_allowed() {
        let text = "version: 1\nn_points: 3\n{\n1 2\nnan nan\n3 4\n}\n";
        assert!(read_pts(text).is_err(), "strict reading refuses NaN");
        let p = read_pts_with_missing(text).unwrap();
        assert_eq!(p[0], [0.0, 1.0]);
        assert!(p[1][0].is_nan() && p[1][1].is_nan());
        assert_eq!(p[2], [2.0, 3.0]);
        assert!(read_pts_with_missing(&text.replace("nan nan", "nan 5")).is_err());
        assert!(read_pts_with_missing(&text.replace("nan nan", "inf inf")).is_err());
    }
}
