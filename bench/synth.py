"""Synthetic faces with known truth (see fit_vs_eos.py's docstring for the choices)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from geometry import (camera_linear, nearest_on_segments, outer_silhouette, project, rotation,
                      self_occluded)
from sfm import CHAIN_PICK, LEFT_CONTOUR_LANDMARKS, RIGHT_CONTOUR_LANDMARKS, SFM

WIDTH, HEIGHT = 1280, 960
YAW_MAX, PITCH_MAX, ROLL_MAX = 85.0, 30.0, 30.0
FACE_PX = (150.0, 500.0)  # face width: distance between the chains' eye-height vertices
MARGIN_PX = 10.0
DROP_FRACTION, DROP_MAX = 0.2, 5
OCCLUSION_YAW = 80.0  # beyond this |yaw|, hidden landmarks are left out
MIDLINE_MM = 10.0  # the far side's outline may cross the midline by this much (nose, lips, chin)
OUTLINE_STEP_MM = 0.5  # probe distance outside an occluding edge for the "outer outline" test


@dataclass
class Face:
    index: int
    shape: np.ndarray  # (63,) SD units
    expression: np.ndarray  # (6,)
    yaw: float
    pitch: float
    roll: float
    scale: float  # px per mm
    t: np.ndarray  # (2,) image translation, px
    verts: np.ndarray  # (N, 3) true mesh, model mm
    clean: np.ndarray  # (68, 2) noise-free landmarks, 0-based px, NaN = not annotated
    noise: np.ndarray  # (68, 2) standard normal draws, scaled by sigma per noise level
    dropped: list = field(default_factory=list)  # iBUG numbers dropped at random
    hidden: list = field(default_factory=list)  # iBUG numbers left out as self-occluded
    toward: str = ""  # "right" or "left": the side of the face turned to the camera
    outline_dist_px: float = 0.0  # mean distance chain vertex -> outline on the away side

    def landmarks(self, sigma: float) -> np.ndarray:
        return self.clean + sigma * self.noise


def make_face(sfm: SFM, seed: int, index: int) -> Face:
    """Face ``index`` of the set with this seed (independent of how many faces are made)."""
    rng = np.random.default_rng([seed, index])
    shape = rng.standard_normal(sfm.basis.shape[1])
    expr = np.where(rng.random(sfm.blendshapes.shape[1]) < 0.5, 0.0,
                    rng.uniform(0.0, 1.0, sfm.blendshapes.shape[1]))
    yaw = rng.uniform(-YAW_MAX, YAW_MAX)
    pitch = rng.uniform(-PITCH_MAX, PITCH_MAX)
    roll = rng.uniform(-ROLL_MAX, ROLL_MAX)
    width_px = rng.uniform(*FACE_PX)
    pos = rng.random(2)
    noise = rng.standard_normal((68, 2))
    n_drop = int(rng.integers(1, DROP_MAX + 1)) if rng.random() < DROP_FRACTION else 0
    drop = sorted(int(x) + 1 for x in rng.choice(68, size=n_drop, replace=False)) if n_drop else []

    verts = sfm.instance(shape, expr)
    rc, lc = sfm.right_chain, sfm.left_chain
    face_mm = float(np.linalg.norm(verts[rc[CHAIN_PICK[0]]] - verts[lc[CHAIN_PICK[0]]]))
    scale = width_px / face_mm
    rot = rotation(yaw, pitch, roll)
    a = camera_linear(rot, scale)
    p0 = project(verts, a, (0.0, 0.0))
    lo, hi = p0.min(axis=0), p0.max(axis=0)
    room = np.array([WIDTH, HEIGHT]) - 2 * MARGIN_PX - (hi - lo)
    if (room < 0).any():
        raise ValueError(f"face {index} does not fit the image")
    t = MARGIN_PX - lo + pos * room
    p2 = p0 + t
    cam = verts @ rot.T
    depth = cam[:, 2]

    pts = np.full((68, 2), np.nan)
    for lm, v in sfm.mapping.items():
        pts[lm - 1] = p2[v]
    # The inner mouth corners (61, 65) have no vertex in the mapping and neither fitter uses them;
    # give them a plausible place: half the mouth corner, a quarter each of the two inner-lip
    # points beside it.
    for lm, (corner, upper, lower) in {61: (49, 62, 68), 65: (55, 64, 66)}.items():
        x = 0.5 * verts[sfm.mapping[corner]] + 0.25 * (verts[sfm.mapping[upper]] + verts[sfm.mapping[lower]])
        pts[lm - 1] = project(x[None, :], a, t)[0]
    # Contour: the side turned to the camera projects the model's outline chain; the side turned
    # away takes the point of the visible outline nearest to where its chain vertex projects.
    toward = "right" if yaw >= 0 else "left"
    near = (RIGHT_CONTOUR_LANDMARKS, rc) if toward == "right" else (LEFT_CONTOUR_LANDMARKS, lc)
    far = (LEFT_CONTOUR_LANDMARKS, lc) if toward == "right" else (RIGHT_CONTOUR_LANDMARKS, rc)
    for lm, k in zip(near[0], CHAIN_PICK):
        pts[lm - 1] = p2[near[1][k]]
    hidden = []
    dists = []
    if abs(yaw) > OCCLUSION_YAW:
        # Near profile: the far side of the face is out of sight; leave its outline out, and any
        # mapped landmark whose vertex is hidden behind the face.
        hidden += list(far[0])
        ids = list(sfm.mapping.items())
        occ = self_occluded([v for _, v in ids], p2, depth, sfm.triangles)
        hidden += [lm for (lm, _), o in zip(ids, occ) if o]
    else:
        # Only the far half of the face (model x on the far side, up to MIDLINE_MM across the
        # midline for the nose, lip and chin profile) can give the far side's outline.
        far_sign = 1.0 if toward == "right" else -1.0  # the subject's left is model +x
        allowed = far_sign * verts[:, 0] > -MIDLINE_MM
        seg = outer_silhouette(p2, depth, cam, sfm.triangles, sfm.edge_faces, sfm.edge_vertices,
                               OUTLINE_STEP_MM * scale, hole_loops=sfm.hole_loops, allowed=allowed)
        for lm, k in zip(far[0], CHAIN_PICK):
            q, d = nearest_on_segments(p2[far[1][k]], seg)
            pts[lm - 1] = q
            dists.append(d)
    hidden = sorted(set(hidden))
    for lm in hidden + drop:
        pts[lm - 1] = np.nan
    return Face(index=index, shape=shape, expression=expr, yaw=yaw, pitch=pitch, roll=roll,
                scale=scale, t=t, verts=verts, clean=pts, noise=noise, dropped=drop,
                hidden=hidden, toward=toward,
                outline_dist_px=float(np.mean(dists)) if dists else float("nan"))
