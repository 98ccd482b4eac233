#!/usr/bin/env bash
# Kiosk start-up under Xvfb: from the kiosk command's start to the first presented frame and to
# the first frame showing the gem, for the build without the face pipeline
# (--no-default-features) and the full build (whose face tracker loads on its own thread: the
# time of the first face from a video is reported too). Writes bench/results/kiosk-startup.md.
# Usage: scripts/bench-kiosk.sh [RUNS]   (default 5)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
runs="${1:-5}"
cargo build --release --locked --no-default-features
cp target/release/glyptic target/release/glyptic-noface
cargo build --release --locked --example make_clip
cargo build --release --locked
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
export XDG_RUNTIME_DIR="$tmp"
./target/release/examples/make_clip "$tmp/clip.avi" 90 >/dev/null

run() { # build-name binary extra-args...
  local name="$1" bin="$2"; shift 2
  for i in $(seq "$runs"); do
    xvfb-run -a -s "-screen 0 1024x1280x24" "$bin" kiosk --trace --size 800x1000 "$@" \
      > "$tmp/$name-$i.jsonl" 2> "$tmp/$name-$i.err" || { cat "$tmp/$name-$i.err" >&2; exit 1; }
  done
}
run noface target/release/glyptic-noface --frames 3
run full target/release/glyptic --video "$tmp/clip.avi" --seconds 6

mkdir -p bench/results
out=bench/results/kiosk-startup.md
python3 - "$tmp" "$runs" > "$out.tmp" <<'PY'
import json, statistics, sys
tmp, runs = sys.argv[1], int(sys.argv[2])
def stats(v):
    v = [x for x in v if x is not None]
    if not v:
        return "-"
    return f"{statistics.median(v):.2f} ({min(v):.2f}-{max(v):.2f})"
print("# Kiosk start-up\n")
print(f"Seconds from the kiosk command's start, median (range) of {runs} runs under Xvfb, window 800x1000, llvmpipe (Vulkan).\n")
print("| build | first frame | first frame showing the gem (half resolution) | the gem at full resolution | first face from the video |")
print("|---|---|---|---|---|")
for name, label in [("noface", "no face pipeline (`--no-default-features`)"), ("full", "full (default features), `--video`")]:
    first, gem, full, face = [], [], [], []
    for i in range(1, runs + 1):
        lines = [json.loads(l) for l in open(f"{tmp}/{name}-{i}.jsonl")]
        last = lines[-1]
        first.append(last["first_frame_s"])
        gem.append(last["first_gem_frame_s"])
        full.append(last["full_gem_frame_s"])
        face.append(next((l["t_s"] for l in lines if l["face_updates"] > 0), None))
    print(f"| {label} | {stats(first)} | {stats(gem)} | {stats(full)} | {stats(face) if name == 'full' else '-'} |")
PY
echo >> "$out.tmp"
echo "Command: \`scripts/bench-kiosk.sh $runs\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))." >> "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
