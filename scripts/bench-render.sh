#!/usr/bin/env bash
# Renderer benchmark: GPU time per pass (scene, SSS, composite) at 640x400 and 1280x800, SSS
# on and off, marble and agate, and the relief rebuild time; writes bench/results/render.md.
# Usage: scripts/bench-render.sh [FRAMES]   (default 9)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
frames="${1:-9}"
cargo build --release --locked --example bench_render
mkdir -p bench/results
out=bench/results/render.md
{
  ./target/release/examples/bench_render "$frames"
  echo
  echo "Command: \`scripts/bench-render.sh $frames\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))."
} > "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
