"""Cameras and mesh geometry for the benchmark (numpy only).

Frames: model millimetres (y up, the face looks along +z); image pixels 0-based, x right, y down.
A scaled-orthographic camera is ``u = A @ X + t`` with ``A = s * diag(1, -1) @ R[:2]``, and the
depth towards the camera is ``(R @ X)_z`` (the camera sits on +z and looks along -z).
"""

from __future__ import annotations

import numpy as np

FLIP = np.diag([1.0, -1.0])


def rotation(yaw_deg: float, pitch_deg: float, roll_deg: float) -> np.ndarray:
    """``R = Rz(roll) @ Ry(yaw) @ Rx(pitch)``: glyptic's convention (and nalgebra's Euler angles).

    Positive yaw turns the subject's right cheek (model -x) towards the camera.
    """
    y, p, r = np.radians([yaw_deg, pitch_deg, roll_deg])
    rx = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rz = np.array([[np.cos(r), -np.sin(r), 0], [np.sin(r), np.cos(r), 0], [0, 0, 1]])
    return rz @ ry @ rx


def camera_linear(rot: np.ndarray, scale: float) -> np.ndarray:
    """The 2x3 linear part ``A`` of a scaled-orthographic camera (image y down)."""
    return scale * FLIP @ rot[:2]


def project(verts: np.ndarray, a: np.ndarray, t) -> np.ndarray:
    return verts @ a.T + np.asarray(t, float)


def best_translation(model_pts: np.ndarray, image_pts: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Least-squares translation for a fixed linear part: the mean residual."""
    return (image_pts - model_pts @ a.T).mean(axis=0)


def rms_after_offset(fit: np.ndarray, truth: np.ndarray) -> float:
    """RMS distance (mm) over vertices after removing the mean offset (no rotation removed)."""
    d = fit - truth
    d = d - d.mean(axis=0)
    return float(np.sqrt((d * d).sum(axis=1).mean()))


def rms_after_rigid(fit: np.ndarray, truth: np.ndarray) -> float:
    """RMS distance (mm) after the best rigid alignment (offset + rotation, Kabsch, no scale)."""
    f = fit - fit.mean(axis=0)
    g = truth - truth.mean(axis=0)
    u, _, vt = np.linalg.svd(f.T @ g)
    d = np.sign(np.linalg.det(u @ vt))
    r = u @ np.diag([1.0, 1.0, d]) @ vt  # rotation taking f onto g: f @ r ~ g
    e = f @ r - g
    return float(np.sqrt((e * e).sum(axis=1).mean()))


def _tri2d(p2: np.ndarray, tris: np.ndarray):
    a, b, c = p2[tris[:, 0]], p2[tris[:, 1]], p2[tris[:, 2]]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    ok = np.abs(det) > 1e-12
    return a[ok], b[ok], c[ok], det[ok], np.nonzero(ok)[0]


def cover_depth(queries: np.ndarray, p2: np.ndarray, depth: np.ndarray, tris: np.ndarray,
                exclude_vertex=None, tol: float = 1e-9, chunk: int = 64) -> np.ndarray:
    """For each 2D query point, the largest depth (towards the camera) of the triangles covering
    it, or -inf where none does. ``exclude_vertex[i]`` (optional) ignores triangles that contain
    that vertex for query ``i``."""
    a, b, c, det, idx = _tri2d(p2, tris)
    tr = tris[idx]
    da, db, dc = depth[tr[:, 0]], depth[tr[:, 1]], depth[tr[:, 2]]
    out = np.full(len(queries), -np.inf)
    for s in range(0, len(queries), chunk):
        q = queries[s:s + chunk, None, :]
        wb = ((q[..., 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (q[..., 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / det
        wc = ((b[:, 0] - a[:, 0]) * (q[..., 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (q[..., 0] - a[:, 0])) / det
        wa = 1.0 - wb - wc
        inside = (wa >= -tol) & (wb >= -tol) & (wc >= -tol)
        if exclude_vertex is not None:
            ex = np.asarray(exclude_vertex[s:s + chunk])[:, None]
            inside &= ~((tr[:, 0] == ex) | (tr[:, 1] == ex) | (tr[:, 2] == ex))
        z = wa * da + wb * db + wc * dc
        z = np.where(inside, z, -np.inf)
        out[s:s + chunk] = z.max(axis=1)
    return out


def self_occluded(vertex_ids, p2, depth, tris, eps_mm: float = 2.0) -> np.ndarray:
    """True where a vertex is hidden behind another part of the mesh (ray towards the camera)."""
    vertex_ids = np.asarray(vertex_ids)
    z = cover_depth(p2[vertex_ids], p2, depth, tris, exclude_vertex=vertex_ids)
    return z > depth[vertex_ids] + eps_mm


def outer_silhouette(p2: np.ndarray, depth: np.ndarray, cam_verts: np.ndarray, tris: np.ndarray,
                     edge_faces: np.ndarray, edge_vertices: np.ndarray, step_px: float,
                     hole_loops=(), allowed=None):
    """Segments (K, 2, 2) of the mesh's visible outline: occluding edges (the two adjacent faces
    flip facing) whose outside, ``step_px`` beyond the edge in the image, no triangle covers.
    Holes in the mesh (``hole_loops``: border edges, e.g. the mouth) are filled for that test, so
    that a lip seen against the mouth slit does not count as outline. ``allowed`` (bool per
    vertex) keeps only edges between allowed vertices."""
    v = cam_verts
    n_z = np.cross(v[tris[:, 1]] - v[tris[:, 0]], v[tris[:, 2]] - v[tris[:, 0]])[:, 2]
    front = n_z > 0
    f0, f1 = edge_faces[:, 0], edge_faces[:, 1]
    sil = front[f0] != front[f1]
    if allowed is not None:
        sil &= allowed[edge_vertices[:, 0]] & allowed[edge_vertices[:, 1]]
    ev, ef = edge_vertices[sil], np.where(front[f0[sil]], f0[sil], f1[sil])
    p0, p1 = p2[ev[:, 0]], p2[ev[:, 1]]
    # The third vertex of the front-facing triangle tells which side of the edge the surface is.
    tri = tris[ef]
    third = np.where((tri != ev[:, :1]) & (tri != ev[:, 1:2]), tri, -1).max(axis=1)
    e = p1 - p0
    length = np.linalg.norm(e, axis=1)
    keep = length > 1e-9
    p0, p1, e, length, third = p0[keep], p1[keep], e[keep], length[keep], third[keep]
    nrm = np.stack([-e[:, 1], e[:, 0]], axis=1) / length[:, None]
    inward = ((p2[third] - p0) * nrm).sum(axis=1) > 0
    nrm[inward] *= -1
    probe = 0.5 * (p0 + p1) + step_px * nrm
    cp2, cdepth, ctris = p2, depth, tris
    for loop in hole_loops:  # fan from the loop's centroid
        c = len(cp2)
        ids = np.unique(loop)
        cp2 = np.vstack([cp2, p2[ids].mean(axis=0)])
        cdepth = np.append(cdepth, depth[ids].mean())
        ctris = np.vstack([ctris, np.column_stack([loop, np.full(len(loop), c)])])
    outside = ~np.isfinite(cover_depth(probe, cp2, cdepth, ctris))
    return np.stack([p0[outside], p1[outside]], axis=1)


def nearest_on_segments(q: np.ndarray, seg: np.ndarray):
    """Nearest point to ``q`` (2,) on any of the segments (K, 2, 2); returns (point, distance)."""
    p0, p1 = seg[:, 0], seg[:, 1]
    e = p1 - p0
    t = np.clip(((q - p0) * e).sum(axis=1) / np.maximum((e * e).sum(axis=1), 1e-18), 0.0, 1.0)
    pts = p0 + t[:, None] * e
    d = np.linalg.norm(pts - q, axis=1)
    k = int(np.argmin(d))
    return pts[k], float(d[k])
