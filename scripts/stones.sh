#!/usr/bin/env bash
# The stones and settings side by side (issue #39), on NASA's portrait of astronaut Eileen
# Collins (public domain; from the scikit-image wheel on PyPI): every stone (marble, agate,
# shell, jasperware), profile and frontal, in every setting (plain bezel, milgrain collet with
# a bail, rope-twist frame), each rendered at 1536x1920 (out/stones/, not committed), then
#   docs/stones.png         the 24 gems in one sheet (a row per stone: profile plain,
#                           milgrain + bail, rope, then frontal the same);
#   docs/stones-detail.png  parts at full size: each setting's rim, the shell's and the
#                           jasperware's thin edges, the marble's veins.
#
#   bash scripts/stones.sh
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
source scripts/astronaut.sh
OUT=out/stones
mkdir -p "$OUT"
astronaut="$OUT/astronaut.png"
fetch_astronaut "$astronaut"

cargo build --release --locked --bin glyptic --example contact_sheet
GLYPTIC=./target/release/glyptic
SHEET=./target/release/examples/contact_sheet
tiles=()
for material in marble agate shell jasperware; do
  for portrait in profile frontal; do
    for setting in plain milgrain rope; do
      bail=off
      [ "$setting" = milgrain ] && bail=on
      png="$OUT/$material-$portrait-$setting.png"
      "$GLYPTIC" photo "$astronaut" -o "$png" --size 1536x1920 --yaw -12 \
        --portrait "$portrait" --material "$material" --setting "$setting" --bail "$bail" \
        >/dev/null
      tiles+=("$png")
    done
  done
  echo "stones: $material"
done
"$SHEET" docs/stones.png 6 240x300 "${tiles[@]}"
# Full-size parts (pixels of the 1536x1920 renders): the bail and the top of each rim, the
# side of the rope, the face's thin edges in shell and jasperware, the marble's ground.
"$SHEET" docs/stones-detail.png 3 480x400 \
  "$OUT/marble-profile-plain.png@528,0,480,400" \
  "$OUT/marble-profile-milgrain.png@528,180,480,400" \
  "$OUT/marble-profile-rope.png@528,60,480,400" \
  "$OUT/shell-profile-plain.png@380,560,480,400" \
  "$OUT/jasperware-frontal-plain.png@520,520,480,400" \
  "$OUT/marble-frontal-plain.png@200,900,480,400"
echo "wrote docs/stones.png and docs/stones-detail.png (renders in $OUT)"
