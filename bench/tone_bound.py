#!/usr/bin/env python3
"""Where a frontal gem's light and dark comes from, and how far it could take a likeness
(issue #37). Two checks on `likeness_embed --out DIR` runs; no network here, numpy and Pillow
only (the bench virtualenv, .deps/bench-venv, has both).

parts ON OFF
    ON and OFF: the same photos made into gems with the tone (ON) and without it
    (`likeness_embed --tone 0`, OFF). Per frontal gem, band-passed as bench/light_and_dark.py
    does and correlated over the face with the photo's: the gem (ON), the relief's own light
    and dark (OFF), and the tone's own part (ON less OFF, in log brightness). Printed: their
    means, and the spreads of the relief's part, the tone's and the photo's.

overlay RUN OUT AMP BLUR [REGION [SIDE]]
    Not a gem: each frontal gem of RUN with its photo's band-passed brightness laid over its
    face (a multiplier, the photo's brightness against its surroundings at 0.25 of the eyes'
    distance, raised to AMP: 1 the photo's own contrast; then blurred by BLUR eyes' distances,
    0 none), aligned by the 68 landmarks found on both. OUT then holds a run to score as
    likeness_embed's (`manifest.tsv`, `judge-input.txt`, the pictures): what a network makes
    of a carved face whose light and dark were that faithful to the photo, the bound the tone
    works towards. REGION keeps the overlay to part of the face: `eyes` (the brows and the
    eyes), `nose`, `mouth` (each the hull of its landmarks grown by 0.12 of the eyes'
    distance), `features` (the three), `rest` (the face without them) or `all` (the
    default; its edge blurred by 0.1 of the eyes' distance, a part's by 0.05); SIDE to its darks (`dark`: the multiplier at most 1), its lights (`light`) or
    `both` (the default): which part of the photo's light and dark a likeness needs.
"""
import os
import sys

import numpy as np
from PIL import Image, ImageDraw, ImageFilter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import light_and_dark as ld  # noqa: E402

SIGMA = 0.25
REGIONS = {"eyes": list(range(17, 27)) + list(range(36, 48)), "nose": list(range(27, 36)),
           "mouth": list(range(48, 68))}


def hull(size, points, grow):
    """The convex hull of `points` on a picture of `size`, grown by `grow` pixels (bool)."""
    centre = points.mean(0)
    order = np.argsort(np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0]))
    mask = Image.new("L", size, 0)
    ImageDraw.Draw(mask).polygon([tuple(points[i]) for i in order], fill=255)
    return np.asarray(mask.filter(ImageFilter.MaxFilter(2 * int(grow) + 1))) > 128


def region_mask(size, g, region):
    """Where the overlay goes (0..1): the face, or one of its `REGIONS` (see overlay)."""
    face = np.asarray(ld.face_mask(size, g), dtype=np.float64) / 255.0
    if region == "all":
        return face
    grow = 0.12 * ld.eye_distance(g)
    parts = {k: hull(size, g[v], grow) for k, v in REGIONS.items()}
    features = parts["eyes"] | parts["nose"] | parts["mouth"]
    if region == "features":
        return features.astype(np.float64)
    if region == "rest":
        return face * ~features
    if region not in parts:
        sys.exit(f"unknown region {region!r}")
    return parts[region].astype(np.float64)


def manifest(run):
    return [line.rstrip("\n").split("\t") for line in open(run + "/manifest.tsv")]


def parts(on, off):
    lm = ld.landmarks(on)
    photos = {int(m[2]): m[3] for m in manifest(on) if m[0] == "photo"}
    rows = []
    for kind, _person, photo, path in manifest(on):
        if kind != "frontal":
            continue
        src, other = photos[int(photo)], path.replace(on, off, 1)
        if src not in lm or path not in lm or not os.path.exists(other):
            continue
        p, g = lm[src], lm[path]
        gem, bare = Image.open(path).convert("L"), Image.open(other).convert("L")
        r = ld.band(Image.open(src).convert("L"), ld.eye_distance(p), SIGMA)
        lo, hi = np.percentile(r, [1, 99])
        r = Image.fromarray(np.float32(np.clip(r, lo, hi)), mode="F")
        mapped = np.asarray(r.transform(gem.size, Image.AFFINE, ld.affine(g, p), resample=Image.BILINEAR))
        inside = np.asarray(ld.face_mask(gem.size, g)) > 128
        iod = ld.eye_distance(g)
        with_tone, without = ld.band(gem, iod, SIGMA)[inside], ld.band(bare, iod, SIGMA)[inside]
        tone, ph = with_tone - without, mapped[inside]
        c = lambda x: np.corrcoef(x, ph)[0, 1]  # noqa: E731
        rows.append([c(with_tone), c(without), c(tone), without.std(), tone.std(), ph.std()])
    if not rows:
        sys.exit("no frontal gem found in both runs with a face on it and on its photo")
    m = np.mean(rows, axis=0)
    print(f"{on} against {off}: {len(rows)} frontal gems; light and dark against the photo's: "
          f"gem {m[0]:.3f}, relief alone {m[1]:.3f}, tone alone {m[2]:.3f}; "
          f"spread: relief {m[3]:.3f}, tone {m[4]:.3f}, photo {m[5]:.3f}")


def overlay(run, out, amp, blur, region="all", side="both"):
    os.makedirs(out + "/pics", exist_ok=True)
    lm = ld.landmarks(run)
    photos = {int(m[2]): m[3] for m in manifest(run) if m[0] == "photo"}
    rows, judge = [], []
    for m in manifest(run):
        if m[0] == "photo":
            rows.append(m)
            if m[3] in lm:
                judge.append((m[3], lm[m[3]]))
            continue
        if m[0] != "frontal":
            continue
        src = photos[int(m[2])]
        if src not in lm or m[3] not in lm:
            continue
        p, g = lm[src], lm[m[3]]
        gem = Image.open(m[3]).convert("RGB")
        photo = Image.open(src).convert("L")
        iod = ld.eye_distance(p)
        lum = np.asarray(photo, dtype=np.float64) + 1.0
        around = np.asarray(photo.filter(ImageFilter.GaussianBlur(SIGMA * iod)), dtype=np.float64) + 1.0
        ratio = Image.fromarray(np.uint8(np.clip(np.clip(lum / around, 0.3, 1.6) ** amp * 128, 0, 255)))
        if blur > 0:
            ratio = ratio.filter(ImageFilter.GaussianBlur(blur * iod))
        ratio = np.asarray(ratio.transform(gem.size, Image.AFFINE, ld.affine(g, p),
                                           resample=Image.BILINEAR, fillcolor=128), dtype=np.float64) / 128.0
        if side == "dark":
            ratio = np.minimum(ratio, 1.0)
        elif side == "light":
            ratio = np.maximum(ratio, 1.0)
        giod = ld.eye_distance(g)
        mask = Image.fromarray(np.uint8(255 * region_mask(gem.size, g, region)))
        mask = mask.filter(ImageFilter.GaussianBlur(0.1 * giod if region == "all" else 0.05 * giod))
        w = np.asarray(mask, dtype=np.float64)[..., None] / 255.0
        picture = np.asarray(gem, dtype=np.float64) * (1 + w * (ratio[..., None] - 1))
        dst = f"{out}/pics/{int(m[2]):03d}.png"
        Image.fromarray(np.uint8(np.clip(picture, 0, 255))).save(dst)
        judge.append((dst, g))
        rows.append(["frontal", m[1], m[2], dst])
    with open(out + "/manifest.tsv", "w") as f:
        f.writelines("\t".join(r) + "\n" for r in rows)
    with open(out + "/judge-input.txt", "w") as f:
        f.writelines(path + " " + " ".join(f"{v:.2f}" for v in q.ravel()) + "\n" for path, q in judge)
    print(f"{out}: {sum(r[0] == 'frontal' for r in rows)} frontal pictures")


def main():
    args = sys.argv[1:]
    if len(args) == 3 and args[0] == "parts":
        parts(args[1], args[2])
    elif 5 <= len(args) <= 7 and args[0] == "overlay":
        overlay(args[1], args[2], float(args[3]), float(args[4]), *args[5:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
