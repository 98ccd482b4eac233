#!/usr/bin/env bash
# Set-up, then the full test suite (release profile: the numerical tests run on real models).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash scripts/setup.sh
source scripts/env.sh
cargo test --release --locked "$@"
