//! The orbit camera and the light, with glam (column-major, as WGSL reads its matrices).
//!
//! The camera circles the mesh's bounding-box centre; yaw turns it about the vertical (+Y) axis,
//! pitch raises it, and yaw = pitch = 0 looks straight at the front (from +Z towards -Z). The
//! distance makes the mesh's bounding sphere fit the narrower field of view with a small
//! margin, so nothing leaves the frame whatever the angles. Clip space is wgpu's: depth in
//! [0, 1].
//!
//! The key light is fixed to the stone (see [`glyptic_core::scene::key_light_dir`]): raking from the upper
//! left, so the relief's slopes and cast shadows read whatever the view.

use glam::{Mat4, Vec3, Vec4};

use crate::mesh::Bounds;

/// Vertical field of view (degrees), as in the 2021 system and the SSS reference demo.
pub const FOV_Y_DEG: f32 = 20.0;
/// Extra room around the bounding sphere (1.0 = touching the frame edge).
const MARGIN: f32 = 1.06;
/// Pitch is kept short of the poles, where the orbit's up vector degenerates.
pub const MAX_PITCH_DEG: f32 = 89.0;

/// Everything the shaders need from the camera for one frame.
#[derive(Clone, Debug)]
pub(crate) struct Camera {
    pub view_proj: Mat4,
    pub eye: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// Viewing direction (from the eye into the scene).
    pub forward: Vec3,
    /// Unit vector towards the light (world space).
    pub light: Vec3,
    /// View-depth range (mm along `forward`) that contains the whole mesh.
    pub near: f32,
    pub far: f32,
}

/// Zoom range: out to twice the fitting distance, in to a quarter of it (still outside the
/// bounding sphere, so the depth range stays valid).
pub const ZOOM_RANGE: (f32, f32) = (0.5, 4.0);

/// Camera for a mesh with `bounds`, seen at `yaw_deg`/`pitch_deg` on a `width` x `height` image,
/// `zoom` times closer than the distance at which the mesh fits (clamped to [`ZOOM_RANGE`]).
pub(crate) fn orbit(
    bounds: &Bounds,
    yaw_deg: f32,
    pitch_deg: f32,
    zoom: f32,
    width: u32,
    height: u32,
) -> Camera {
    let aspect = width as f32 / height.max(1) as f32;
    let half_fov_y = (FOV_Y_DEG * 0.5).to_radians();
    let half_fov_x = (aspect * half_fov_y.tan()).atan();
    let half_fov = half_fov_y.min(half_fov_x);
    // A floor on the radius keeps a degenerate (single point) mesh from putting the eye on it.
    let radius = bounds.radius.max(1e-3);
    let zoom = if zoom.is_finite() {
        zoom.clamp(ZOOM_RANGE.0, ZOOM_RANGE.1)
    } else {
        1.0
    };
    let distance = MARGIN * radius / half_fov.sin() / zoom;

    let yaw = yaw_deg.to_radians();
    let pitch = pitch_deg.clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG).to_radians();
    let center = Vec3::from(bounds.center);
    let offset = Vec3::new(
        yaw.sin() * pitch.cos(),
        pitch.sin(),
        yaw.cos() * pitch.cos(),
    );
    let eye = center + offset * distance;
    let forward = -offset;
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let view = Mat4::look_to_rh(eye, forward, Vec3::Y);
    // Depth range: the bounding sphere with a little slack, so no part is ever clipped.
    let near = (distance - radius * 1.05).max(distance * 0.01);
    let far = distance + radius * 1.05;
    // Right-handed, depth 0..1 over near..far: wgpu's clip space.
    let projection = Mat4::perspective_rh(2.0 * half_fov_y, aspect, near, far);

    let light = Vec3::from(glyptic_core::scene::key_light_dir());
    Camera {
        view_proj: projection * view,
        eye,
        right,
        up,
        forward,
        light,
        near,
        far,
    }
}

/// The part of the frame the scene and SSS passes draw (pixels, from the top left): the
/// mesh's projection with a margin. Everything outside it is backdrop, which the composite
/// paints without reading the scene's targets, so those targets need only this size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Crop {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

/// Empty pixels kept round the mesh's projection: MSAA samples lie inside their pixel, and the
/// SSS's taps beyond the crop are clamped to its edge, which must be empty there as it is in
/// the full frame.
const CROP_MARGIN_PX: f32 = 3.0;

/// Crop sizes are rounded up to this (pixels), so a turning gem reuses its targets.
pub(crate) const CROP_STEP_PX: u32 = 64;

/// The pixel box `[x0, y0, x1, y1]` (clamped to the frame, margin included) that holds every
/// vertex of the mesh as `view_proj` projects it on a `width` x `height` frame; the whole
/// frame if a vertex is not in front of the eye (the orbit keeps them all in front).
pub(crate) fn mesh_box(
    view_proj: &Mat4,
    positions: impl Iterator<Item = [f32; 3]>,
    width: u32,
    height: u32,
) -> [u32; 4] {
    let (w, h) = (width as f32, height as f32);
    let full = [0, 0, width, height];
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for p in positions {
        let c = *view_proj * Vec4::new(p[0], p[1], p[2], 1.0);
        // Behind the eye, or not a number: project nothing, draw everything.
        if c.w.is_nan() || c.w <= 1e-6 {
            return full;
        }
        let px = [(c.x / c.w + 1.0) * 0.5 * w, (1.0 - c.y / c.w) * 0.5 * h];
        for a in 0..2 {
            lo[a] = lo[a].min(px[a]);
            hi[a] = hi[a].max(px[a]);
        }
    }
    if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
        return full;
    }
    let clamp = |v: f32, max: u32| v.clamp(0.0, max as f32) as u32;
    [
        clamp((lo[0] - CROP_MARGIN_PX).floor(), width),
        clamp((lo[1] - CROP_MARGIN_PX).floor(), height),
        clamp((hi[0] + CROP_MARGIN_PX).ceil(), width),
        clamp((hi[1] + CROP_MARGIN_PX).ceil(), height),
    ]
}

impl Crop {
    /// The crop of `size` (at most the frame's) centred on `bounds` (`mesh_box`'s output) and
    /// moved inside the frame.
    pub fn around(bounds: [u32; 4], size: [u32; 2], width: u32, height: u32) -> Crop {
        let place = |lo: u32, hi: u32, len: u32, frame: u32| {
            let len = len.min(frame);
            let slack = len.saturating_sub(hi.saturating_sub(lo));
            lo.saturating_sub(slack / 2).min(frame - len)
        };
        let (cw, ch) = (size[0].min(width), size[1].min(height));
        Crop {
            x: place(bounds[0], bounds[2], cw, width),
            y: place(bounds[1], bounds[3], ch, height),
            width: cw,
            height: ch,
        }
    }

    /// The targets' size for a mesh box: its size rounded up to [`CROP_STEP_PX`], at most the
    /// frame's.
    pub fn size_for(bounds: [u32; 4], width: u32, height: u32) -> [u32; 2] {
        let round = |len: u32, frame: u32| {
            len.max(1)
                .div_ceil(CROP_STEP_PX)
                .saturating_mul(CROP_STEP_PX)
                .min(frame)
        };
        [
            round(bounds[2].saturating_sub(bounds[0]), width),
            round(bounds[3].saturating_sub(bounds[1]), height),
        ]
    }

    /// Maps the full frame's clip space to the crop's: applied after the view-projection, the
    /// scene lands in the crop's targets exactly where its pixels lie in the frame (whole-pixel
    /// offsets, so MSAA's samples fall on the geometry as they would uncropped).
    pub fn clip_matrix(&self, width: u32, height: u32) -> Mat4 {
        let (w, h) = (width as f32, height as f32);
        let (cw, ch) = (self.width.max(1) as f32, self.height.max(1) as f32);
        let (x0, y0) = (self.x as f32, self.y as f32);
        Mat4::from_cols(
            Vec4::new(w / cw, 0.0, 0.0, 0.0),
            Vec4::new(0.0, h / ch, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 1.0, 0.0),
            Vec4::new((w - cw - 2.0 * x0) / cw, (ch - h + 2.0 * y0) / ch, 0.0, 1.0),
        )
    }
}

/// View-projection of face `face` (0..6: +X, -X, +Y, -Y, +Z, -Z) of a shadow cube at `lamp`,
/// 90 degrees square, depth [0, 1] over `near`..`far` (mm). Laid out so that a direction `d`
/// from the lamp lands where a cube texture lookup with `d` reads (the cube-map face and
/// (s, t) rules of the Vulkan and GL specs, with wgpu's rows running down as NDC y falls).
pub(crate) fn cube_face_view_proj(lamp: Vec3, face: usize, near: f32, far: f32) -> Mat4 {
    // The classic GL table (target, up); GL's rows run up with NDC y, wgpu's down, so y is
    // negated after projecting.
    let (target, up) = match face {
        0 => (Vec3::X, Vec3::NEG_Y),
        1 => (Vec3::NEG_X, Vec3::NEG_Y),
        2 => (Vec3::Y, Vec3::Z),
        3 => (Vec3::NEG_Y, Vec3::NEG_Z),
        4 => (Vec3::Z, Vec3::NEG_Y),
        _ => (Vec3::NEG_Z, Vec3::NEG_Y),
    };
    let view = Mat4::look_to_rh(lamp, target, up);
    let (n, f) = (near, far);
    let proj = Mat4::from_cols(
        Vec4::new(1.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, -1.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, f / (n - f), -1.0),
        Vec4::new(0.0, 0.0, n * f / (n - f), 0.0),
    );
    proj * view
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds() -> Bounds {
        Bounds {
            min: [-22.0, -28.0, -3.0],
            max: [22.0, 28.0, 8.0],
            center: [0.0, 0.0, 2.5],
            radius: 36.1,
        }
    }

    fn project(c: &Camera, p: [f32; 3]) -> [f32; 3] {
        let h = c.view_proj * Vec4::new(p[0], p[1], p[2], 1.0);
        [h.x / h.w, h.y / h.w, h.z / h.w]
    }

    #[test]
    fn yaw_zero_looks_at_the_front() {
        let c = orbit(&bounds(), 0.0, 0.0, 1.0, 160, 200);
        assert!(c.eye.z > 50.0 && c.eye.x.abs() < 1e-4 && c.eye.y.abs() < 1e-4);
        let centre = project(&c, [0.0, 0.0, 2.5]);
        assert!(centre[0].abs() < 1e-5 && centre[1].abs() < 1e-5);
        // +X appears to the right and +Y up.
        assert!(project(&c, [10.0, 0.0, 2.5])[0] > 0.0);
        assert!(project(&c, [0.0, 10.0, 2.5])[1] > 0.0);
        // Light from the upper left, raking (15-25 degrees above the stone), and fixed to the
        // stone: the same from another view.
        assert!(c.light.x < 0.0 && c.light.y > 0.0 && c.light.z > 0.0);
        let elevation = c.light.z.asin().to_degrees();
        assert!((15.0..=25.0).contains(&elevation), "{elevation}");
        let turned = orbit(&bounds(), 50.0, 20.0, 1.0, 160, 200);
        assert_eq!(turned.light, c.light);
    }

    /// The cube lookup of the specs: face index and (s, t) in [0, 1] for a direction.
    fn cube_lookup(d: [f32; 3]) -> (usize, f32, f32) {
        let [x, y, z] = d;
        let (face, sc, tc, ma) = if x.abs() >= y.abs() && x.abs() >= z.abs() {
            if x > 0.0 {
                (0, -z, -y, x)
            } else {
                (1, z, -y, -x)
            }
        } else if y.abs() >= z.abs() {
            if y > 0.0 {
                (2, x, z, y)
            } else {
                (3, x, -z, -y)
            }
        } else if z > 0.0 {
            (4, x, -y, z)
        } else {
            (5, -x, -y, -z)
        };
        (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
    }

    #[test]
    fn shadow_cube_faces_land_where_the_lookup_reads() {
        let lamp = Vec3::new(-50.0, 60.0, 40.0);
        let dirs = [
            [1.0, 0.2, -0.3],
            [-1.0, 0.4, 0.1],
            [0.3, 1.0, -0.6],
            [-0.2, -1.0, 0.5],
            [0.7, -0.1, 1.0],
            [-0.4, 0.6, -1.0],
        ];
        for d in dirs {
            let (face, s, t) = cube_lookup(d);
            let m = cube_face_view_proj(lamp, face, 1.0, 300.0);
            let p = lamp + Vec3::from(d) * 37.0;
            let h = m * p.extend(1.0);
            let (x, y, z) = (h.x / h.w, h.y / h.w, h.z / h.w);
            // wgpu: column = (x + 1) / 2, row = (1 - y) / 2.
            let (col, row) = (0.5 * (x + 1.0), 0.5 * (1.0 - y));
            assert!(
                (col - s).abs() < 1e-5 && (row - t).abs() < 1e-5,
                "{d:?}: face {face} ({col}, {row}) vs ({s}, {t})"
            );
            assert!(z > 0.0 && z < 1.0);
        }
    }

    #[test]
    fn zoom_moves_the_eye_along_the_view() {
        let far = orbit(&bounds(), 20.0, 10.0, 1.0, 160, 200);
        let near = orbit(&bounds(), 20.0, 10.0, 2.0, 160, 200);
        let centre = Vec3::from(bounds().center);
        let (df, dn) = ((far.eye - centre).length(), (near.eye - centre).length());
        assert!((df / dn - 2.0).abs() < 1e-4, "{df} / {dn}");
        assert!((far.forward - near.forward).length() < 1e-6);
        // Clamped: no closer than ZOOM_RANGE allows, and NaN means no zoom.
        let inside = orbit(&bounds(), 0.0, 0.0, 1e6, 160, 200);
        let limit = orbit(&bounds(), 0.0, 0.0, ZOOM_RANGE.1, 160, 200);
        assert_eq!(inside.eye, limit.eye);
        assert_eq!(
            orbit(&bounds(), 0.0, 0.0, f32::NAN, 160, 200).eye,
            far_eye(&bounds())
        );
        assert!(inside.near > 0.0);
    }

    fn far_eye(b: &Bounds) -> Vec3 {
        orbit(b, 0.0, 0.0, 1.0, 160, 200).eye
    }

    #[test]
    fn the_crop_holds_the_mesh_where_the_frame_has_it() {
        let b = bounds();
        let corners: Vec<[f32; 3]> = (0..8)
            .map(|c| [0, 1, 2].map(|a| if c >> a & 1 == 1 { b.max[a] } else { b.min[a] }))
            .collect();
        for (w, h, yaw, zoom) in [
            (640, 800, 0.0, 1.0),
            (1280, 800, 35.0, 1.0),
            (300, 200, -70.0, 3.0),
        ] {
            let c = orbit(&b, yaw, 10.0, zoom, w, h);
            let bx = mesh_box(&c.view_proj, corners.iter().copied(), w, h);
            assert!(
                bx[0] < bx[2] && bx[1] < bx[3] && bx[2] <= w && bx[3] <= h,
                "{bx:?}"
            );
            let size = Crop::size_for(bx, w, h);
            let crop = Crop::around(bx, size, w, h);
            assert!(crop.x <= bx[0] && crop.y <= bx[1], "{crop:?} {bx:?}");
            assert!(crop.x + crop.width >= bx[2] && crop.y + crop.height >= bx[3]);
            assert!(crop.x + crop.width <= w && crop.y + crop.height <= h);
            let m = crop.clip_matrix(w, h) * c.view_proj;
            for p in &corners {
                // Frame pixel and crop pixel of the same point differ by the crop's origin.
                let full = c.view_proj * Vec4::new(p[0], p[1], p[2], 1.0);
                let cropped = m * Vec4::new(p[0], p[1], p[2], 1.0);
                let fx = (full.x / full.w + 1.0) * 0.5 * w as f32;
                let fy = (1.0 - full.y / full.w) * 0.5 * h as f32;
                let cx = (cropped.x / cropped.w + 1.0) * 0.5 * crop.width as f32;
                let cy = (1.0 - cropped.y / cropped.w) * 0.5 * crop.height as f32;
                assert!((fx - cx - crop.x as f32).abs() < 1e-2, "{fx} {cx} {crop:?}");
                assert!((fy - cy - crop.y as f32).abs() < 1e-2, "{fy} {cy} {crop:?}");
                assert_eq!(full.z / full.w, cropped.z / cropped.w);
            }
        }
        // A point behind the eye: the whole frame.
        let c = orbit(&b, 0.0, 0.0, 1.0, 64, 48);
        let behind = c.eye + 2.0 * (c.eye - Vec3::from(b.center));
        assert_eq!(
            mesh_box(&c.view_proj, [behind.to_array()].into_iter(), 64, 48),
            [0, 0, 64, 48]
        );
    }

    #[test]
    fn sphere_fits_at_any_angle() {
        for (w, h) in [(160, 200), (1280, 800), (100, 1000)] {
            for yaw in [0.0f32, 30.0, 90.0, 180.0, 271.0] {
                for pitch in [-95.0f32, -40.0, 0.0, 60.0] {
                    let c = orbit(&bounds(), yaw, pitch, 1.0, w, h);
                    for corner in 0..8 {
                        let b = bounds();
                        let p = [0, 1, 2].map(|a| {
                            if corner >> a & 1 == 1 {
                                b.max[a]
                            } else {
                                b.min[a]
                            }
                        });
                        let q = project(&c, p);
                        assert!(q.iter().all(|v| v.is_finite()));
                        assert!(
                            q[0].abs() <= 1.0 && q[1].abs() <= 1.0,
                            "{q:?} at {yaw}/{pitch}"
                        );
                        assert!(q[2] > 0.0 && q[2] < 1.0);
                    }
                }
            }
        }
    }
}
