#!/usr/bin/env python3
"""What keeps a frontal gem from its person's photos in a recognition network's space (issue
#37): the part every gem shares (the stone's own look, one offset for all) against the part
that is the person's. No network here: numpy and Pillow only (the bench virtualenv,
.deps/bench-venv, has both); the descriptors come from a judge file (`PATH d1 d2 ...` per
picture: dlib's `dlib.txt` of a run, or `likeness_embed --sface-judge DIR` for SFace).

score RUN JUDGE THRESHOLD
    RUN: a `likeness_embed --out DIR` run. The gems' common offset (their descriptors' mean
    less the photos'), against the spread of each (mean distance to their own mean); the
    people nearest the mean gem (a "hub": the photos every weak gem falls to), where the
    held-out misses go; and, per gem over the photos of the others (its own photo left out):
    its nearest photo's person right, and its mean distance to its person's other photos
    under THRESHOLD, as the descriptors are and with the common offset taken off every gem.
    Taking it off is no gem (the judge would need to know the stone): it says how much of
    the distance is the stone's look, the same for everyone, and how much the person's.

transform RUN OUT KIND [ARG]
    Not a gem: each frontal gem of RUN changed by KIND, written with the photos into OUT as
    a run to judge and score again (`manifest.tsv`, `judge-input.txt`: the landmarks found
    on the gem stay, the geometry does not change). Which change to the picture moves the
    common offset: `tint` (the stone coloured as the photo's skin, the face's mean colour;
    ARG its power, 1 all of it), `grey`, `contrast` (about the face's mean, times ARG),
    `gamma` (ARG), `blur` (Gaussian, ARG pixels), `darken` (all but the face times ARG),
    `paste-REGION` (the photo's own grey pixels, warped by the landmarks and scaled to the
    gem's brightness there, in REGION: `face`, `eyes` (the eyes and brows), `nose`, `mouth`,
    `rest` as bench/tone_bound.py's regions, `openings` (the eyes' openings alone: the hulls
    of their six landmarks grown by 0.06 of the eyes' distance) or `outside`: all but the
    face).

paired JUDGE BASE VARIANT [BASE VARIANT ...]
    Two runs of the same photos (a change and the product, say), in pairs, one pair per photo
    set; JUDGE the judge file's name in each run (`dlib.txt`, or `sface.txt` written by
    `likeness_embed --sface-judge`). Per gem found in both runs of a pair: its mean distance
    to its person's other photos, and its margin (that less its distance to the nearest
    photo of someone else), the variant's less the base's. Printed: the mean differences and
    their standard errors over every pair's gems (negative: the variant's gems nearer their
    people). A share that moves by a gem or two is often noise; a paired difference of
    several standard errors is not.
"""
import collections
import os
import sys

import numpy as np
from PIL import Image, ImageFilter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import light_and_dark as ld  # noqa: E402
import tone_bound as tb  # noqa: E402


def descriptors(path):
    out = {}
    for line in open(path):
        p = line.split()
        if len(p) > 10 and "ERROR" not in p:
            out[p[0]] = np.array(list(map(float, p[1:])))
    return out


def score(run, judge, threshold):
    d = descriptors(judge)
    rows = tb.manifest(run)
    photos = [(int(m[1]), int(m[2]), m[3]) for m in rows if m[0] == "photo" and m[3] in d]
    gems = {int(m[2]): m[3] for m in rows if m[0] == "frontal" and m[3] in d}
    name = {pid: path.split("/")[-2] for pid, _, path in photos}
    pairs = [(pid, j) for pid, j, _ in photos if j in gems]
    if not pairs:
        sys.exit(f"{run}: no frontal gem with a descriptor in {judge}")
    P = np.array([d[q] for _, _, q in photos])
    G = np.array([d[gems[j]] for _, j in pairs])
    offset = G.mean(0) - P.mean(0)
    spread = lambda X: np.linalg.norm(X - X.mean(0), axis=1).mean()  # noqa: E731
    print(f"{run}: {len(pairs)} frontal gems, {len(photos)} photos")
    print(f"  common offset {np.linalg.norm(offset):.3f}; spread: photos {spread(P):.3f}, gems {spread(G):.3f}")
    people = collections.defaultdict(list)
    for pid, _, q in photos:
        people[pid].append(d[q])
    hub = sorted((np.linalg.norm(G.mean(0) - np.mean(v, 0)), name[pid]) for pid, v in people.items())
    print("  nearest the mean gem: " + ", ".join(f"{n} {x:.3f}" for x, n in hub[:3]))
    for label, shift in (("as judged", 0.0 * offset), ("common offset off", offset)):
        right = under = n = 0
        misses = collections.Counter()
        for pid, j in pairs:
            g = d[gems[j]] - shift
            others = [(np.linalg.norm(g - d[q]), p2) for p2, j2, q in photos if j2 != j]
            own = [x for x, p2 in others if p2 == pid]
            if not own:
                continue
            n += 1
            nearest = min(others)[1]
            right += nearest == pid
            misses[name[nearest]] += nearest != pid
            under += np.mean(own) < threshold
        worst = ", ".join(f"{k} {v}" for k, v in misses.most_common(2) if v)
        print(f"  {label}: nearest photo own person (held out) {right}/{n} = {100 * right / n:.0f} %, "
              f"own photos under {threshold} {under}/{n} = {100 * under / n:.0f} %; misses go to: {worst or 'none'}")


def face_mean_colour(img, lm):
    mask = np.asarray(ld.face_mask(img.size, lm)) > 128
    return np.asarray(img, dtype=np.float64)[mask].mean(0)


def transform(run, out, kind, arg=1.0):
    os.makedirs(out + "/frontal", exist_ok=True)
    lm = ld.landmarks(run)
    rows = tb.manifest(run)
    photos = {int(m[2]): m[3] for m in rows if m[0] == "photo"}
    moved = {}
    for m in rows:
        if m[0] != "frontal" or m[3] not in lm or photos[int(m[2])] not in lm:
            continue
        src = photos[int(m[2])]
        g, p = lm[m[3]], lm[src]
        gem = Image.open(m[3]).convert("RGB")
        a = np.asarray(gem, dtype=np.float64)
        face = np.asarray(ld.face_mask(gem.size, g)) > 128
        if kind == "tint":
            a = a * (face_mean_colour(Image.open(src).convert("RGB"), p) / a[face].mean(0)) ** arg
        elif kind == "grey":
            a = a.mean(2, keepdims=True).repeat(3, 2)
        elif kind == "contrast":
            mean = a[face].mean()
            a = mean + (a - mean) * arg
        elif kind == "gamma":
            a = 255.0 * (a / 255.0) ** arg
        elif kind == "blur":
            a = np.asarray(gem.filter(ImageFilter.GaussianBlur(arg)), dtype=np.float64)
        elif kind == "darken":
            soft = ld.face_mask(gem.size, g).filter(ImageFilter.GaussianBlur(3))
            w = np.asarray(soft, dtype=np.float64)[..., None] / 255.0
            a = a * (w + (1.0 - w) * arg)
        elif kind.startswith("paste-"):
            region = kind[len("paste-"):]
            iod = ld.eye_distance(g)
            if region == "openings":
                w = (tb.hull(gem.size, g[36:42], 0.06 * iod) | tb.hull(gem.size, g[42:48], 0.06 * iod)).astype(np.float64)
                edge = 0.03
            else:
                base = "all" if region in ("face", "outside") else region
                w = tb.region_mask(gem.size, g, base)
                if region == "outside":
                    w = 1.0 - w
                edge = 0.05
            soft = Image.fromarray(np.uint8(w * 255)).filter(ImageFilter.GaussianBlur(edge * iod))
            w = np.asarray(soft, dtype=np.float64)[..., None] / 255.0
            grey = Image.open(src).convert("L").transform(gem.size, Image.AFFINE, ld.affine(g, p), resample=Image.BILINEAR)
            grey = np.asarray(grey, dtype=np.float64)[..., None]
            where = w[..., 0] > 0.5
            if where.any():
                grey = grey * (a[where].mean() / max(grey[where].mean(), 1.0))
            a = a * (1.0 - w) + grey * w
        else:
            sys.exit(f"unknown change {kind!r}\n\n{__doc__}")
        path = f"{out}/frontal/{os.path.basename(m[3])}"
        Image.fromarray(np.uint8(np.clip(a, 0, 255))).save(path)
        moved[m[3]] = path
    with open(out + "/manifest.tsv", "w") as f:
        for r in rows:
            if r[0] == "photo" or r[3] in moved:
                f.write("\t".join(r[:3] + [moved.get(r[3], r[3])] + r[4:]) + "\n")
    with open(out + "/judge-input.txt", "w") as f:
        for line in open(run + "/judge-input.txt"):
            path, rest = line.split(" ", 1)
            if path in moved:
                f.write(moved[path] + " " + rest)
            elif path in photos.values():
                f.write(line)
    print(f"{out}: {len(moved)} frontal pictures")


def per_gem(run, judge):
    """Per frontal gem (by its photo's index): its mean distance to its person's other photos
    and that less its distance to the nearest other person's photo."""
    d = descriptors(f"{run}/{judge}")
    rows = [line.rstrip("\n").split("\t") for line in open(f"{run}/manifest.tsv")]
    photos = [(int(r[1]), int(r[2]), r[3]) for r in rows if r[0] == "photo"]
    gems = {int(r[2]): r[3] for r in rows if r[0] == "frontal"}
    out = {}
    for person, j, _ in photos:
        gem = gems.get(j)
        if gem not in d:
            continue
        dist = [(np.linalg.norm(d[gem] - d[q]), who) for who, k, q in photos if k != j and q in d]
        own = [x for x, who in dist if who == person]
        others = [x for x, who in dist if who != person]
        if own and others:
            out[j] = (np.mean(own), np.mean(own) - min(others))
    return out


def paired(judge, runs):
    diffs = []
    for base, variant in zip(runs[::2], runs[1::2]):
        a, b = per_gem(base, judge), per_gem(variant, judge)
        diffs += [np.subtract(b[j], a[j]) for j in a if j in b]
    if not diffs:
        sys.exit("no gem found in both runs of any pair")
    d = np.array(diffs)
    se = d.std(axis=0) / np.sqrt(len(d))
    print(f"{len(d)} gems: distance to their people's other photos {d[:, 0].mean():+.4f} "
          f"+- {se[0]:.4f}; margin over the nearest stranger {d[:, 1].mean():+.4f} +- {se[1]:.4f}")


def main():
    args = sys.argv[1:]
    if len(args) == 4 and args[0] == "score":
        score(args[1], args[2], float(args[3]))
    elif len(args) >= 4 and len(args) % 2 == 0 and args[0] == "paired":
        paired(args[1], args[2:])
    elif 4 <= len(args) <= 5 and args[0] == "transform":
        transform(args[1], args[2], args[3], *map(float, args[4:]))
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
