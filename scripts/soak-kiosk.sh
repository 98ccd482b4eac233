#!/usr/bin/env bash
# Kiosk soak under Xvfb: a looping video (lenna swaying, with sensor noise, 30 frames/s) until
# FRAMES video frames have gone through the face thread; reports resident memory after warm-up
# and at the end (the highest over a minute each), the longest the window spent looking at the
# other threads, the face latency, and gems built and presented. Writes
# bench/results/kiosk-soak.md; fails if memory grew 5 % or more after warm-up or the window ever
# waited 250 ms.
# Usage: scripts/soak-kiosk.sh [FRAMES]   (default 10000; about 6 minutes)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
frames="${1:-10000}"
cargo build --release --locked --example make_clip
cargo build --release --locked
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
export XDG_RUNTIME_DIR="$tmp"
./target/release/examples/make_clip "$tmp/clip.avi" 300 640x480 >/dev/null
# The video plays in real time: FRAMES / 30 seconds, and a little for start-up.
seconds=$(( frames / 30 + 8 ))
xvfb-run -a -s "-screen 0 1024x1280x24" ./target/release/glyptic kiosk --video "$tmp/clip.avi" \
  --trace --size 800x1000 --seconds "$seconds" > "$tmp/soak.jsonl" 2> "$tmp/soak.err" \
  || { cat "$tmp/soak.err" >&2; exit 1; }
mkdir -p bench/results
out=bench/results/kiosk-soak.md
# The verdict is the analysis's exit code; the report is written either way.
status=0
python3 - "$tmp/soak.jsonl" "$frames" > "$out.tmp" <<'PY' || status=$?
import json, statistics, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
want = int(sys.argv[2])
last = lines[-1]
end_t = last["t_s"]
# The highest resident size over a stretch just after warm-up against the last stretch as
# long: one reading swings by tens of MB (a gem's build and frame come and go, and the gem
# thread gives freed pages back every 2 s), a leak raises the high-water mark.
span = min(60.0, end_t / 5)
peak = lambda a, b: max(l["rss_kb"] for l in lines if a <= l["t_s"] <= b)
warm = {"rss_kb": peak(span, 2 * span), "t_s": span}
end = {"rss_kb": peak(end_t - span, end_t), "t_s": end_t}
growth = end["rss_kb"] / warm["rss_kb"] - 1
lat = sorted(l["face_latency_ms"] for l in lines if l["face_updates"] > 0)
p = lambda q: lat[min(len(lat) - 1, int(q * (len(lat) - 1) + 0.5))]
ok = growth < 0.05 and last["poll_max_ms"] < 250 and last["face_frame"] + 1 >= want
print("# Kiosk soak\n")
print(f"* video frames through the face thread: {last['face_frame'] + 1} (wanted {want}) in {end_t:.0f} s")
print(f"* gems built: {last['gems']}; frames presented: {last['frame']}")
print(f"* resident memory, highest over {span:.0f} s: {warm['rss_kb'] / 1024:.1f} MB after warm-up ({span:.0f}-{2 * span:.0f} s), {end['rss_kb'] / 1024:.1f} MB at the end: **{growth * 100:+.2f} %** (limit +5 %)")
print(f"* longest the window spent taking news from the other threads: **{last['poll_max_ms']:.2f} ms** (limit 250 ms; it never waits)")
print(f"* face latency (capture to fit) of the updates the window took: median {p(0.5):.1f} ms, p95 {p(0.95):.1f} ms, max {lat[-1]:.1f} ms")
print(f"* verdict: {'pass' if ok else 'FAIL'}")
sys.exit(0 if ok else 1)
PY
echo >> "$out.tmp"
echo "Command: \`scripts/soak-kiosk.sh $frames\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))." >> "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
exit $status
