#!/usr/bin/env python3
"""The face's proportions on frontal gems against their photos (issue #37): whether the relief
keeps the person's geometry as a landmark detector reads it. No network: this program's own
68 landmarks (`glyptic landmarks --json`) on each photo, its frontal gem and its fitted face
alone (`likeness_embed --out DIR` runs), as ratios to the eye corners' distance (jaw and chin
width, nose length and width, mouth, brows, eyes).

Printed per ratio, over all runs given: the means on photos, gems and fitted faces; the gem
over the photo; and over pairs of one person's photos (A, B != A) the correlation of photo A
with photo B (how far the ratio is the person's, not the picture's), of gem A with photo B,
and of fitted face A with photo B.

Usage: bench/gem_geometry.py RUN... (GLYPTIC: the binary, default target/release/glyptic;
landmarks are cached in RUN/geometry-cache/). numpy only."""
import itertools
import json
import math
import os
import subprocess
import sys

import numpy as np

GLYPTIC = os.environ.get("GLYPTIC", "target/release/glyptic")


def landmarks(path, cache):
    os.makedirs(cache, exist_ok=True)
    c = os.path.join(cache, path.strip("/").replace("/", "_") + ".json")
    if not os.path.exists(c):
        r = subprocess.run([GLYPTIC, "landmarks", path, "--json"], capture_output=True, text=True)
        try:
            pts = json.loads(r.stdout)["faces"][0]["landmarks"]
        except (ValueError, KeyError, IndexError):
            pts = None
        with open(c, "w") as f:
            json.dump(pts, f)
    with open(c) as f:
        return json.load(f)


def ratios(p):
    d = lambda a, b: math.dist(p[a], p[b])  # noqa: E731
    iod = d(36, 45)
    eyes, mouth = np.mean([p[36], p[45]], 0), np.mean([p[48], p[54]], 0)
    return {
        "jaw width": d(2, 14) / iod, "face width": d(0, 16) / iod, "chin width": d(5, 11) / iod,
        "nose length": d(27, 33) / iod, "nose width": d(31, 35) / iod,
        "mouth width": d(48, 54) / iod, "eyes to mouth": math.dist(eyes, mouth) / iod,
        "nasion to chin": d(27, 8) / iod, "mouth to chin": math.dist(mouth, p[8]) / iod,
        "brow to eye": (d(19, 37) + d(24, 44)) / 2 / iod, "eye width": (d(36, 39) + d(42, 45)) / 2 / iod,
        "lips' height": d(51, 57) / iod,
    }


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    items = []
    for run in sys.argv[1:]:
        cache = os.path.join(run, "geometry-cache")
        rows = [l.rstrip("\n").split("\t") for l in open(run + "/manifest.tsv") if l.startswith("photo")]
        for k, r in enumerate(rows):
            found = [landmarks(p, cache) for p in (r[3], f"{run}/frontal/{k:03d}.png", f"{run}/fitted/{k:03d}.png")]
            if all(found):
                items.append((run + r[1], *map(ratios, found)))
    pairs = [(a, b) for a, b in itertools.permutations(items, 2) if a[0] == b[0]]
    print(f"{len(items)} photos with a gem and a fitted face read, {len(pairs)} same-person pairs")
    print("| ratio | photo | gem | fitted | gem / photo | photo A ~ photo B | gem A ~ photo B | fitted A ~ photo B |")
    print("|---|---|---|---|---|---|---|---|")
    for key in items[0][1]:
        ph, gem, fit = (np.array([i[k][key] for i in items]) for k in (1, 2, 3))
        pb = np.array([b[1][key] for _, b in pairs])
        c = [np.corrcoef([a[k][key] for a, _ in pairs], pb)[0, 1] for k in (1, 2, 3)]
        print(f"| {key} | {ph.mean():.3f} | {gem.mean():.3f} | {fit.mean():.3f} | {gem.mean() / ph.mean():.3f} "
              f"| {c[0]:.2f} | {c[1]:.2f} | {c[2]:.2f} |")


if __name__ == "__main__":
    main()
