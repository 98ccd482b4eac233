#!/usr/bin/env bash
# The kiosk's gem while the visitor turns it: the build without the face pipeline (the default
# gem) at 800x1000 under Xvfb, a steady drag across the gem injected with xdotool (3 px every
# 50 ms for 3 s: 63 degrees of yaw), and from the kiosk's trace the rate of gem frames while it moves, their
# render times, and the still frame's after the hand rests (the drag alone: the kiosk's ease
# back to the front after its idle time is not counted). Writes bench/results/orbit.md.
# Usage: scripts/bench-orbit.sh [RUNS] [BINARY]   (default 3 runs of this checkout's build
# without the face pipeline; BINARY, e.g. an older build's, is run with --camera 63 instead, a
# camera that is not there: the default gem all the same). Frames "while turning" are the gem
# frames whose yaw differs from the previous gem frame's.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/ready.sh"
runs="${1:-3}"
bin="${2:-}"
if [ -z "$bin" ]; then
  cargo build --release --locked --no-default-features
  cp target/release/glyptic target/release/glyptic-noface
  cargo build --release --locked
  bin=target/release/glyptic-noface
  extra=()
else
  extra=(--camera 63)
fi
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
export XDG_RUNTIME_DIR="$tmp"

cat > "$tmp/drag.sh" <<'SH'
#!/usr/bin/env bash
# Inside Xvfb: start the kiosk, wait for its full-size gem, drag across the gem, let it rest.
set -euo pipefail
trace="$1"; bin="$2"; shift 2
"$bin" kiosk --trace --size 800x1000 --seconds 16 "$@" > "$trace" &
kiosk=$!
for _ in $(seq 150); do
  grep -q '"full_gem_frame_s":[0-9]' "$trace" 2>/dev/null && break
  sleep 0.1
done
read -r x y < <(tail -n1 "$trace" | python3 -c '
import json, sys
r = json.loads(sys.stdin.read())["controls"]["gem"]
print(int(r[0] + r[2] / 2 - 150), int(r[1] + r[3] / 2))')
moves=""
for i in $(seq 60); do moves="$moves mousemove --window %1 $((x + 3 * i)) $y sleep 0.05"; done
# shellcheck disable=SC2086
xdotool search --name '^glyptic$' mousemove --window %1 "$x" "$y" sleep 0.3 mousedown 1 $moves mouseup 1
wait "$kiosk"
SH
chmod +x "$tmp/drag.sh"
for i in $(seq "$runs"); do
  xvfb-run -a -s "-screen 0 1024x1280x24" "$tmp/drag.sh" "$tmp/trace-$i.jsonl" "$bin" "${extra[@]}" 2> "$tmp/err-$i" \
    || { cat "$tmp/err-$i" >&2; exit 1; }
done

mkdir -p bench/results
out=bench/results/orbit.md
python3 - "$runs" "$tmp" "$bin" > "$out.tmp" <<'PY'
import json, statistics, sys
runs, tmp = int(sys.argv[1]), sys.argv[2]
rows = []
for i in range(1, runs + 1):
    lines = [json.loads(l) for l in open(f"{tmp}/trace-{i}.jsonl") if l.startswith("{")]
    gems = [l for l in lines if l["gem_rendered"]]
    # The drag alone: the first unbroken run of gem frames each at another yaw than the one
    # before. It ends where the hand rests (a gem frame at the same yaw: the still frame);
    # the kiosk's ease back to the front after its idle time is a later run, not counted.
    moving = []
    for a, b in zip(gems, gems[1:]):
        if b["yaw_deg"] != a["yaw_deg"]:
            moving.append(b)
        elif moving:
            break
    if len(moving) < 2:
        sys.exit(f"run {i}: {len(moving)} moving gem frames: the drag did not turn the gem")
    t0, t1 = moving[0]["t_s"], moving[-1]["t_s"]
    after = [l for l in gems if l["t_s"] > t1]
    rows.append({
        "fps": (len(moving) - 1) / (t1 - t0),
        "moving_ms": statistics.median(l["render_ms"] for l in moving),
        "moving_size": moving[0].get("gem_size", "-"),
        "still_ms": after[0]["render_ms"] if after else float("nan"),
        "still_size": after[0].get("gem_size", "-") if after else None,
        "frames": len(moving),
        "yaw": moving[-1]["yaw_deg"],
    })
print(f"# The kiosk's gem while it turns (800x1000 window, default gem; {sys.argv[3]})\n")
print("| run | gem frames while turning | frames/s | moving frame ms (median) | moving size | still frame ms | still size | yaw reached |")
print("|---|---|---|---|---|---|---|---|")
for i, r in enumerate(rows, 1):
    print(f"| {i} | {r['frames']} | {r['fps']:.1f} | {r['moving_ms']:.1f} | {r['moving_size']} | {r['still_ms']:.1f} | {r['still_size']} | {r['yaw']:.0f} |")
print(f"\nMedian frames/s while turning: {statistics.median(r['fps'] for r in rows):.1f}.")
PY
echo >> "$out.tmp"
echo "Command: \`scripts/bench-orbit.sh $runs\` (glyptic $(git rev-parse --short HEAD), $(date -u '+%F %H:%M UTC'), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg))." >> "$out.tmp"
mv "$out.tmp" "$out"
cat "$out"
