#!/usr/bin/env python3
"""Where a frontal gem's light and dark comes from, and how far it could take a likeness
(issue #37). Checks on `likeness_embed --out DIR` runs; no network here, numpy and Pillow
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
    distance; `left-eye` and `right-eye`, each eye with its brow), `features` (the three),
    `rest` (the face without them) or `all` (the default; its edge blurred by 0.1 of the
    eyes' distance, a part's by 0.05); SIDE to its darks (`dark`: the multiplier at most 1),
    its lights (`light`) or `both` (the default): which part of the photo's light and dark a
    likeness needs.

paste RUN OUT REGION [HOW]
    Not a gem: each frontal gem of RUN with its photo's own grey pixels pasted over REGION
    (aligned by the 68 landmarks; the paste's edge blurred by 0.05 of the eyes' distance),
    scaled to the gem's mean brightness there; OUT holds a run to score as overlay's. REGION:
    overlay's, or `openings` (the eyes' openings grown by 0.05 of the eyes' distance),
    `brows` (each brow's points grown by 0.08), `lids` (each eye grown by 0.15, less its
    opening grown by 0.03). HOW says which part of the photo's light and dark goes in:
    `raw` (the default), `blur:S` (blurred, S eyes' distances), `levels:N` (N grey levels),
    `contrast:K` (its spread about its mean times K), `detail` (its light and dark against
    `CURVE_SIGMA` on the gem's own broad light), `clip:Q` (the same with its darks clipped at
    the Q quantile: saturated as a stone's), `dark` (the same, lights dropped), `clip-dark:Q`
    (both), `gem-blur:S` (no photo: the gem itself blurred): what a network needs of the
    eyes, and what the stone must draw.

curve RUN [REGION]
    How the gem's light and dark follows the photo's: per frontal gem of RUN, the photo carried
    into the gem's frame (by the 68 landmarks found on both) and both band-passed at
    `CURVE_SIGMA` of the eyes' distance (log brightness against its surroundings), over REGION
    (as paste's; `eyes` by default). Printed: the correlation (the mean of the gems' and
    pooled), the spreads, and the transfer curve, the gem's mean band-pass in each tenth of the
    photo's (darkest first): where it flattens the stone cannot follow the photo (its darks
    saturate, or its lights are lost). The gem's darkest and median brightness in the eyes'
    openings against its face's median, and the photo's, say how dark the stone can go.
"""
import os
import sys

import numpy as np
from PIL import Image, ImageDraw, ImageFilter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import light_and_dark as ld  # noqa: E402

SIGMA = 0.25
# The stipple's band (the detail's STIPPLE_BAND): what a gem's darks are read against.
CURVE_SIGMA = 0.1
REGIONS = {"eyes": list(range(17, 27)) + list(range(36, 48)), "nose": list(range(27, 36)),
           "mouth": list(range(48, 68)),
           # The eye and brow on the picture's left (the key light's side, upper left) and right.
           "left-eye": list(range(17, 22)) + list(range(36, 42)),
           "right-eye": list(range(22, 27)) + list(range(42, 48))}


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


def remade(run, out, make):
    """A run to score as likeness_embed's in OUT (`manifest.tsv`, `judge-input.txt`, the
    pictures): RUN's photos, and each frontal gem with a face on it and on its photo remade
    by `make(gem path, photo path, photo landmarks, gem landmarks)` (a picture)."""
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
        dst = f"{out}/pics/{int(m[2]):03d}.png"
        make(m[3], src, lm[src], lm[m[3]]).save(dst)
        judge.append((dst, lm[m[3]]))
        rows.append(["frontal", m[1], m[2], dst])
    with open(out + "/manifest.tsv", "w") as f:
        f.writelines("\t".join(r) + "\n" for r in rows)
    with open(out + "/judge-input.txt", "w") as f:
        f.writelines(path + " " + " ".join(f"{v:.2f}" for v in q.ravel()) + "\n" for path, q in judge)
    print(f"{out}: {sum(r[0] == 'frontal' for r in rows)} frontal pictures")


def overlay(run, out, amp, blur, region="all", side="both"):
    remade(run, out, lambda gem, src, p, g: overlaid(gem, src, p, g, amp, blur, region, side))


def overlaid(path, src, p, g, amp, blur, region, side):
    """One gem of `overlay`."""
    gem = Image.open(path).convert("RGB")
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
    return Image.fromarray(np.uint8(np.clip(picture, 0, 255)))


def blur_array(a, sigma):
    """A float picture blurred by a Gaussian of `sigma` pixels (edges clamped; as it is at 0)."""
    if sigma <= 0:
        return np.asarray(a, dtype=np.float64)
    r = int(3 * sigma) + 1
    x = np.arange(-r, r + 1)
    k = np.exp(-x * x / (2 * sigma * sigma))
    k /= k.sum()
    along = lambda v: np.convolve(np.pad(v, r, mode="edge"), k, "valid")  # noqa: E731
    return np.apply_along_axis(along, 1, np.apply_along_axis(along, 0, a))


def paste_mask(size, g, region):
    """Where `paste` puts the photo (bool)."""
    iod = ld.eye_distance(g)
    eyes = (g[36:42], g[42:48])
    if region == "openings":
        return hull(size, eyes[0], 0.05 * iod) | hull(size, eyes[1], 0.05 * iod)
    if region == "brows":
        return hull(size, g[17:22], 0.08 * iod) | hull(size, g[22:27], 0.08 * iod)
    if region == "lids":
        outer = hull(size, eyes[0], 0.15 * iod) | hull(size, eyes[1], 0.15 * iod)
        return outer & ~(hull(size, eyes[0], 0.03 * iod) | hull(size, eyes[1], 0.03 * iod))
    return region_mask(size, g, region) > 0.5


def pasted(photo, gem, inside, iod, how):
    """The photo's grey pixels (in the gem's frame) as `paste`'s HOW asks, float."""
    kind, _, arg = how.partition(":")
    scale = lambda q: q * (gem[inside].mean() / max(q[inside].mean(), 1.0))  # noqa: E731
    if kind == "raw":
        return scale(photo)
    if kind == "blur":
        return scale(blur_array(photo, float(arg) * iod))
    if kind == "levels":
        q, n = scale(photo), int(arg)
        lo, hi = np.percentile(q[inside], [2, 98])
        t = np.round(np.clip((q - lo) / max(hi - lo, 1.0), 0, 1) * (n - 1)) / (n - 1)
        return lo + t * (hi - lo)
    if kind == "contrast":
        q = scale(photo)
        mean = q[inside].mean()
        return mean + float(arg) * (q - mean)
    if kind == "gem-blur":
        return blur_array(gem, float(arg) * iod)
    if kind in ("detail", "clip", "dark", "clip-dark"):
        sigma = CURVE_SIGMA * iod
        rel = np.log(photo + 1) - np.log(blur_array(photo, sigma) + 1)
        if kind in ("clip", "clip-dark"):
            rel = np.maximum(rel, np.quantile(rel[inside], float(arg)))
        if kind in ("dark", "clip-dark"):
            rel = np.minimum(rel, 0.0)
        return np.exp(np.log(blur_array(gem, sigma) + 1) + rel) - 1
    sys.exit(f"unknown HOW {how!r}")


def paste(run, out, region, how="raw"):
    remade(run, out, lambda gem, src, p, g: pasted_over(gem, src, p, g, region, how))


def pasted_over(path, src, p, g, region, how):
    """One gem of `paste`."""
    picture = Image.open(path).convert("RGB")
    photo = Image.open(src).convert("L").transform(picture.size, Image.AFFINE, ld.affine(g, p),
                                                  resample=Image.BILINEAR)
    iod = ld.eye_distance(g)
    rgb = np.asarray(picture, dtype=np.float64)
    inside = paste_mask(picture.size, g, region)
    q = pasted(np.asarray(photo, dtype=np.float64), rgb.mean(2), inside, iod, how)
    w = blur_array(inside.astype(np.float64), 0.05 * iod)[..., None]
    rgb = rgb * (1 - w) + np.clip(q, 0, 255)[..., None] * w
    return Image.fromarray(np.uint8(np.clip(rgb, 0, 255)))


def curve(run, region="eyes"):
    lm = ld.landmarks(run)
    photos = {int(m[2]): m[3] for m in manifest(run) if m[0] == "photo"}
    ph_all, gem_all, corr, depth = [], [], [], []
    for m in manifest(run):
        if m[0] != "frontal":
            continue
        src = photos[int(m[2])]
        if src not in lm or m[3] not in lm:
            continue
        p, g = lm[src], lm[m[3]]
        gem = Image.open(m[3]).convert("L")
        photo = Image.open(src).convert("L").transform(gem.size, Image.AFFINE, ld.affine(g, p),
                                                      resample=Image.BILINEAR)
        iod = ld.eye_distance(g)
        inside = paste_mask(gem.size, g, region)
        if inside.sum() < 50:
            continue
        a, b = ld.band(photo, iod, CURVE_SIGMA)[inside], ld.band(gem, iod, CURVE_SIGMA)[inside]
        ph_all.append(a)
        gem_all.append(b)
        corr.append(np.corrcoef(a, b)[0, 1])
        face = np.asarray(ld.face_mask(gem.size, g)) > 128
        opening = hull(gem.size, g[36:42], 0.05 * iod) | hull(gem.size, g[42:48], 0.05 * iod)
        row = []
        for pic in (gem, photo):
            v = np.asarray(pic, dtype=np.float64)
            med = max(np.median(v[face]), 1.0)
            row += [np.percentile(v[opening], 2) / med, np.median(v[opening]) / med]
        depth.append(row)
    if not ph_all:
        sys.exit("no frontal gem with a face on it and on its photo")
    a, b = np.concatenate(ph_all), np.concatenate(gem_all)
    edges = np.quantile(a, np.linspace(0, 1, 11))
    which = np.clip(np.searchsorted(edges, a, side="right") - 1, 0, 9)
    d = np.mean(depth, axis=0)
    print(f"{run}, {region}: {len(corr)} frontal gems; correlation {np.mean(corr):.3f} (pooled "
          f"{np.corrcoef(a, b)[0, 1]:.3f}); spread: gem {b.std():.3f}, photo {a.std():.3f}")
    print("photo's tenths: " + " ".join(f"{a[which == k].mean():6.2f}" for k in range(10)))
    print("gem's mean:     " + " ".join(f"{b[which == k].mean():6.2f}" for k in range(10)))
    print(f"eyes' openings against the face's median: gem darkest (2nd percentile) {d[0]:.2f}, "
          f"median {d[1]:.2f}; photo {d[2]:.2f}, {d[3]:.2f}")


def main():
    args = sys.argv[1:]
    if len(args) == 3 and args[0] == "parts":
        parts(args[1], args[2])
    elif 4 <= len(args) <= 5 and args[0] == "paste":
        paste(*args[1:])
    elif 2 <= len(args) <= 3 and args[0] == "curve":
        curve(*args[1:])
    elif 5 <= len(args) <= 7 and args[0] == "overlay":
        overlay(args[1], args[2], float(args[3]), float(args[4]), *args[5:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
