#!/usr/bin/env bash
# The kiosk's screenshot set in docs/ (README, deploy/README.md), each from a real kiosk run in a
# virtual X display (Xvfb, lavapipe) at a portrait kiosk screen's shape:
#   docs/kiosk-attract.png  nobody there: the default gem turning under the invitation
#   docs/kiosk-live.png     a visitor: NASA's portrait of astronaut Eileen Collins (public
#                           domain; from the scikit-image wheel on PyPI) shown to the kiosk as
#                           a camera would see it (`--video PHOTO`)
#   docs/kiosk-staff.png    the staff panel over the kiosk, with no camera plugged in
#
#   bash scripts/kiosk-screenshots.sh [SIZE]      (default 600x900)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
source scripts/astronaut.sh
SIZE=${1:-600x900}
OUT=out/kiosk-shots
mkdir -p "$OUT" docs
astronaut="$OUT/astronaut.png"
fetch_astronaut "$astronaut"

cargo build --release --locked --bin glyptic
GLYPTIC=./target/release/glyptic

# A virtual screen of its own, on a free display number (written to the file once it listens).
tmp="$(mktemp -d)"
Xvfb -displayfd 5 -screen 0 1280x1280x24 -nolisten tcp 5>"$tmp/display" 2>/dev/null &
xvfb=$!
trap 'kill "$xvfb" 2>/dev/null || true; rm -rf "$tmp"' EXIT
for _ in $(seq 100); do [ -s "$tmp/display" ] && break; sleep 0.1; done
export DISPLAY=":$(tr -d '[:space:]' < "$tmp/display")"

# Attract mode soon after the start (nobody is there from the start).
quick="$OUT/quick.toml"
printf 'idle_seconds = 1.0\nattract_seconds = 1.0\n' > "$quick"

echo "kiosk-screenshots: attract"
"$GLYPTIC" -q kiosk --config "$quick" --camera 57 --size "$SIZE" --seconds 16 \
  --screenshot docs/kiosk-attract.png
echo "kiosk-screenshots: live (the astronaut's photo as the camera)"
"$GLYPTIC" -q kiosk --video "$astronaut" --size "$SIZE" --seconds 40 \
  --screenshot docs/kiosk-live.png
echo "kiosk-screenshots: staff panel"
"$GLYPTIC" -q kiosk --camera 57 --size "$SIZE" --seconds 14 --staff \
  --screenshot docs/kiosk-staff.png
ls -l docs/kiosk-*.png
