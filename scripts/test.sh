#!/usr/bin/env bash
# Set-up, then the full test suite (release profile: the numerical tests run on real models).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
source scripts/env.sh
# The build without the face pipeline (fast development start) must keep working: build it
# and keep its binary for the kiosk tests (the default build below replaces target's glyptic).
cargo build --release --locked --no-default-features
cp target/release/glyptic target/release/glyptic-noface
cargo test --release --locked --workspace "$@"
