#!/usr/bin/env python3
"""How much of a photo's fine light and dark its frontal gem shows (issue #37): a measure of
the likeness that no recognition network gives, so nothing is tuned to one network.

For every frontal gem of a `likeness_embed --out DIR` run, the photo's brightness is mapped
onto the gem by the affine map that carries the photo's 68 landmarks onto the gem's (both as
the run found them, `DIR/judge-input.txt`), both are band-passed (log brightness against its
Gaussian surroundings, sigma SIGMA of the eyes' distance, default 0.25) and correlated over
the face (the jaw's outline and the brows lifted by 0.3 of the eyes' distance). Printed: the
gems measured, the mean and the median correlation. The photo with itself gives 1; a gem with
the photo's band-passed brightness laid over its face 0.75 (issue #37's throwaway check).

Usage: bench/light_and_dark.py DIR [SIGMA]   (numpy and Pillow: the bench virtualenv that
scripts/bench-fit.sh makes, .deps/bench-venv, has both)."""
import sys

import numpy as np
from PIL import Image, ImageDraw, ImageFilter


def landmarks(run):
    out = {}
    for line in open(run + "/judge-input.txt"):
        p = line.split()
        out[p[0]] = np.array(list(map(float, p[1:])), dtype=np.float64).reshape(-1, 2)
    return out


def eye_distance(p):
    return float(np.linalg.norm(p[36:42].mean(0) - p[42:48].mean(0)))


def band(img, iod, sigma):
    lum = np.asarray(img, dtype=np.float64) + 1.0
    around = np.asarray(img.filter(ImageFilter.GaussianBlur(sigma * iod)), dtype=np.float64) + 1.0
    return np.log(lum / around)


def affine(gem_lm, photo_lm):
    """PIL's affine coefficients carrying gem pixels to photo pixels (least squares)."""
    a, *_ = np.linalg.lstsq(np.c_[gem_lm, np.ones(len(gem_lm))], photo_lm, rcond=None)
    return (a[0, 0], a[1, 0], a[2, 0], a[0, 1], a[1, 1], a[2, 1])


def face_mask(size, g):
    """The face on a picture of `size` with landmarks `g`: the jaw's outline and the brows
    lifted by 0.3 of the eyes' distance, filled with 255."""
    iod = eye_distance(g)
    mask = Image.new("L", size, 0)
    outline = list(g[0:17]) + list(g[26:16:-1] - np.array([0.0, 0.3 * iod]))
    ImageDraw.Draw(mask).polygon([tuple(q) for q in outline], fill=255)
    return mask


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    run = sys.argv[1]
    sigma = float(sys.argv[2]) if len(sys.argv) > 2 else 0.25
    lm = landmarks(run)
    manifest = [l.rstrip("\n").split("\t") for l in open(run + "/manifest.tsv")]
    photos = {int(m[2]): m[3] for m in manifest if m[0] == "photo"}
    corr = []
    for kind, _person, photo, path in manifest:
        if kind != "frontal":
            continue
        src = photos[int(photo)]
        if src not in lm or path not in lm:
            continue  # no face found on the photo or on the gem
        p, g = lm[src], lm[path]
        gem = Image.open(path).convert("L")
        ph = Image.open(src).convert("L")
        r = band(ph, eye_distance(p), sigma)
        lo, hi = np.percentile(r, [1, 99])
        r = Image.fromarray(np.float32(np.clip(r, lo, hi)), mode="F")
        mapped = np.asarray(
            r.transform(gem.size, Image.AFFINE, affine(g, p), resample=Image.BILINEAR))
        giod = eye_distance(g)
        inside = np.asarray(face_mask(gem.size, g)) > 128
        corr.append(np.corrcoef(band(gem, giod, sigma)[inside], mapped[inside])[0, 1])
    corr = np.array(corr)
    if len(corr) == 0:
        sys.exit("no frontal gem with a face found on it and on its photo")
    print(f"{run}: {len(corr)} frontal gems, light and dark against the photo's: "
          f"mean correlation {corr.mean():.3f}, median {np.median(corr):.3f}")


if __name__ == "__main__":
    main()
