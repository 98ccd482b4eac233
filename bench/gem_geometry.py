#!/usr/bin/env python3
"""The face's proportions on frontal gems against their photos (issue #37): whether the relief
keeps the person's geometry as a landmark detector reads it. No network: the 68 landmarks
a `likeness_embed --out DIR` run found (this program's own, `DIR/judge-input.txt`) on each
photo, its frontal gem and its fitted face alone, as ratios to the eye corners' distance (jaw
and chin width, nose length and width, mouth, brows, eyes).

Printed per ratio, over all runs given: the means on photos, gems and fitted faces; the gem
over the photo; and over pairs of one person's photos (A, B != A) the correlation of photo A
with photo B (how far the ratio is the person's, not the picture's), of gem A with photo B,
and of fitted face A with photo B.

Usage: bench/gem_geometry.py RUN...   (numpy: the bench virtualenv, .deps/bench-venv)."""
import itertools
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import light_and_dark as ld  # noqa: E402


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
        lm = ld.landmarks(run)
        rows = [l.rstrip("\n").split("\t") for l in open(run + "/manifest.tsv")]
        made = {(r[0], r[2]): r[3] for r in rows}
        for r in rows:
            paths = [r[3], made.get(("frontal", r[2])), made.get(("fitted", r[2]))]
            if r[0] == "photo" and all(p in lm for p in paths):
                items.append((run + r[1], *(ratios(lm[p]) for p in paths)))
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
