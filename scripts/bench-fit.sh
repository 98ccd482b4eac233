#!/usr/bin/env bash
# glyptic's landmark fitting against eos-py 1.5.0 on identical inputs (speed and accuracy).
# Usage: scripts/bench-fit.sh [--quick] [bench/fit_vs_eos.py options...]
# Writes bench/results/fit_vs_eos.md, bench/results/fit_vs_eos_cases.csv and docs/bench-fit.png.
# Idempotent: runs scripts/setup.sh, makes (once) the virtualenv .deps/bench-venv with the pinned
# PyPI packages below, builds glyptic only if target/release/glyptic is missing.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

bash scripts/setup.sh
source scripts/env.sh

VENV="$ROOT/.deps/bench-venv"
REQS=(eos-py==1.5.0 numpy==2.4.6 matplotlib==3.11.2)
STAMP="$VENV/.bench-requirements"
# eos-py 1.5.0 ships binary wheels for CPython 3.8-3.13; prefer 3.11, the version it was tried on.
PY=""
for cand in python3.11 python3.12 python3.13 python3.10 python3; do
  if command -v "$cand" >/dev/null 2>&1; then PY="$cand"; break; fi
done
[ -n "$PY" ] || { echo "bench-fit: error: no python3 found" >&2; exit 1; }
if [ ! -x "$VENV/bin/python" ] || [ "$(cat "$STAMP" 2>/dev/null || true)" != "${REQS[*]}" ]; then
  echo "bench-fit: making $VENV (${REQS[*]})"
  rm -rf "$VENV"
  "$PY" -m venv "$VENV"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=eos-py "${REQS[@]}"
  printf '%s' "${REQS[*]}" > "$STAMP"
else
  echo "bench-fit: virtualenv present ($VENV)"
fi

if [ ! -x target/release/glyptic ]; then
  echo "bench-fit: building glyptic (cargo build --release --locked)"
  cargo build --release --locked
fi

export BENCH_COMMAND="scripts/bench-fit.sh${*:+ $*}"
exec "$VENV/bin/python" bench/fit_vs_eos.py "$@"
