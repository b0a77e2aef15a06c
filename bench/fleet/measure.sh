#!/usr/bin/env bash
# The recorder's and the live view's figures for a fleet (README "Record, replay and the live
# view"). From the repository root, after `cmake --build build --target fleet_generator locctl
# locview` and scripts/node-setup, inside a network namespace of your own:
#   ip netns exec NS bench/fleet/measure.sh [ROBOTS=100] [SECONDS=20] [DOMAIN=125]
# 1. locctl record records fleet_generator's ROBOTS robots for SECONDS: messages/s, MB/s, drops
#    and the recorder's CPU time.
# 2. locview serves the same fleet while a Foxglove client connects subscribed to nothing, then
#    to every channel, then nothing, then every channel (interleaved, SECONDS each): locview's CPU
#    share in each phase, from /proc/PID/stat.
set -euo pipefail
robots=${1:-100}
seconds=${2:-20}
domain=${3:-125}
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"
out=$(mktemp -d)
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

echo "== 1. locctl record, $robots robots, $seconds s"
/usr/bin/time -f '{"recorder_user_s":%U,"recorder_system_s":%S,"recorder_max_rss_kb":%M}' -o "$out/time.json" \
  build/bin/locctl record "$out/fleet.mcap" --domain "$domain" --duration $((seconds + 5)) --json > "$out/record.json" &
recorder=$!
sleep 1
build/bin/fleet_generator --domain "$domain" --robots "$robots" --seconds "$seconds"
wait $recorder
cat "$out/record.json" "$out/time.json"
python3 - "$out/record.json" "$seconds" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); s = float(sys.argv[2])
print(f"recorded over the generator's {s:.0f} s: {r['messages']/s:.0f} messages/s, {r['payload_bytes']/s/1e6:.2f} MB/s of samples, "
      f"file {r['file_bytes']/s/1e6:.2f} MB/s (zstd), dropped {r['dropped']}")
PY

echo "== 2. locview, $robots robots: CPU with no subscription vs every channel subscribed"
build/bin/locview --domain "$domain" --port 0 --address 127.0.0.1 > "$out/view.log" 2>&1 &
view=$!
for _ in $(seq 50); do grep -q "serving" "$out/view.log" && break; sleep 0.1; done
port=$(sed -n 's/.*ws:\/\/127\.0\.0\.1:\([0-9]*\).*/\1/p' "$out/view.log")
build/bin/fleet_generator --domain "$domain" --robots "$robots" --seconds $((4 * seconds + 8)) > /dev/null &
generator=$!
sleep 6  # discovery: every robot advertised
cpu() { awk '{print $14 + $15}' "/proc/$view/stat"; }
for mode in none all none all; do
  before=$(cpu); start=$(date +%s.%N)
  node build/node/view_subscribe.mjs "ws://127.0.0.1:$port" "$mode" "$seconds" > "$out/client.json"
  after=$(cpu); end=$(date +%s.%N)
  python3 -c "import json,sys; c=json.load(open('$out/client.json')); t=$end-$start; print(f'$mode: locview CPU {($after-$before)/100/t*100:.1f} % of one core over {t:.1f} s; client got {c[\"messages\"]/t:.0f} messages/s, {c[\"bytes\"]/t/1e6:.2f} MB/s on {c[\"subscribed\"]} of {c[\"channels\"]} channels')"
done
kill $generator 2>/dev/null || true
wait $generator 2>/dev/null || true
kill $view
wait $view 2>/dev/null || true
tail -n 1 "$out/view.log"  # messages sent and dropped (a client's queue full)
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
rm -rf "$out"
