# Sourced by the benchmark and gallery scripts: into the repository root, set-up done (quietly,
# idempotent) and the run-time environment (scripts/env.sh) in place.
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/setup.sh >/dev/null
source scripts/env.sh
