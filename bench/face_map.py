#!/usr/bin/env python3
"""Where on the face the frontal gems carry their people's light and dark (issue #37): a map
that no recognition network gives, so nothing is tuned to one network.

For every frontal gem of one or more `likeness_embed --out DIR` runs with a face found on it
and on its photo, both pictures are band-passed (log brightness against its Gaussian
surroundings, sigma SIGMA of the eyes' distance, as bench/light_and_dark.py), divided by their
face's own spread (1.4826 times the median absolute value over the face), and carried into
one frame (256 x 256 pixels) by the affine map that puts the eyes' centres, the nose's tip,
the mouth's corners and the chin at fixed places. Per pixel of that frame, over all gems:
the photos' mean, the gems' mean, and the correlation across gems between a gem and its
photo (1: the gem's light and dark there goes with its person's; 0: the same on every gem,
or unrelated). Printed: the gems, the mean correlation per region of the frame (eyes,
brows, nose, mouth, cheeks) and the mean of each side in the eyes' openings and the mouth.

Usage: bench/face_map.py OUT.png SIGMA RUN [RUN...]
   OUT.png: photos' mean | gems' mean | correlation (black 0, white 0.8), twice the size.
(numpy and Pillow: the bench virtualenv that scripts/bench-fit.sh makes, .deps/bench-venv.)"""
import sys

import numpy as np
from PIL import Image

from light_and_dark import band, eye_distance, face_mask, landmarks

SIZE = 256
# Where the eyes' centres, the nose's tip (iBUG 31), the mouth's corners (49, 55) and the
# chin (9) go in the frame.
TEMPLATE = np.array([[88, 100], [168, 100], [128, 150], [98, 185], [158, 185], [128, 235]], float)
# Regions of the frame: rows, columns.
REGIONS = {
    "eyes": (slice(88, 112), slice(70, 186)),
    "brows": (slice(66, 88), slice(60, 196)),
    "nose": (slice(112, 165), slice(105, 151)),
    "mouth": (slice(172, 200), slice(88, 168)),
    "cheeks": (slice(120, 170), np.r_[55:95, 161:201]),
}


def to_frame(p):
    """PIL's affine coefficients carrying frame pixels to picture pixels (least squares)."""
    src = np.array([p[36:42].mean(0), p[42:48].mean(0), p[30], p[48], p[54], p[8]])
    a, *_ = np.linalg.lstsq(np.c_[TEMPLATE, np.ones(len(TEMPLATE))], src, rcond=None)
    return (a[0, 0], a[1, 0], a[2, 0], a[0, 1], a[1, 1], a[2, 1])


def framed(path, p, sigma):
    img = Image.open(path).convert("L")
    r = band(img, eye_distance(p), sigma)
    face = np.asarray(face_mask(img.size, p)) > 128
    r = np.clip(r / (1.4826 * np.median(np.abs(r[face])) + 1e-6), -6, 6)
    f = Image.fromarray(np.float32(r), mode="F")
    return np.asarray(f.transform((SIZE, SIZE), Image.AFFINE, to_frame(p), resample=Image.BILINEAR))


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    out, sigma, runs = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
    photos, gems = [], []
    for run in runs:
        lm = landmarks(run)
        manifest = [l.rstrip("\n").split("\t") for l in open(run + "/manifest.tsv")]
        sources = {int(m[2]): m[3] for m in manifest if m[0] == "photo"}
        for kind, _person, photo, path in manifest:
            src = sources.get(int(photo))
            if kind != "frontal" or src not in lm or path not in lm:
                continue
            photos.append(framed(src, lm[src], sigma))
            gems.append(framed(path, lm[path], sigma))
    if len(gems) < 3:
        sys.exit("fewer than three frontal gems with a face found on them and their photos")
    a, b = np.array(photos), np.array(gems)
    da, db = a - a.mean(0), b - b.mean(0)
    corr = (da * db).mean(0) / (da.std(0) * db.std(0) + 1e-6)
    print(f"{len(gems)} frontal gems, band {sigma} of the eyes' distance")
    print("correlation gem ~ photo across gems: " + ", ".join(
        f"{k} {corr[r][:, c].mean():.3f}" for k, (r, c) in REGIONS.items()))
    for k in ("eyes", "mouth"):
        r, c = REGIONS[k]
        print(f"{k}: photos' mean {a.mean(0)[r][:, c].mean():+.2f}, gems' {b.mean(0)[r][:, c].mean():+.2f}"
              " (the face's spreads)")

    def grey(x, lo, hi):
        return Image.fromarray(np.uint8(np.clip(255 * (x - lo) / (hi - lo), 0, 255)))

    sheet = Image.new("L", (3 * SIZE + 10, SIZE), 255)
    for i, t in enumerate([grey(a.mean(0), -3, 3), grey(b.mean(0), -3, 3), grey(corr, 0, 0.8)]):
        sheet.paste(t, (i * (SIZE + 5), 0))
    sheet.resize((2 * sheet.width, 2 * sheet.height)).save(out)


if __name__ == "__main__":
    main()
