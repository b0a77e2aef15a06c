#!/usr/bin/env bash
# The server's latency against the DDS floor, in one run (README quotes the output), in a network
# namespace on loopback made here:
#   1. ddsperf ping/pong (Cyclone's own tool): round trip through a second process that only
#      echoes, the floor of any "publish -> answer" path on this machine;
#   2. locd_latency_probe: odometry published -> pose received through locd and the
#      fixture_odometry plugin (a few microseconds of compute) in a worker process: a round trip
#      through the server.
# Both at 200 messages/s. Usage (as root, from the repository root): bench/fleet/latency.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds="${1:-15}"
source bench/lib/loopback_namespace.sh

run ddsperf -D "$((seconds + 2))" pong > /dev/null 2>&1 &
run ddsperf -D "$seconds" ping 200Hz > "$work/ping.txt" 2>&1 || true
wait
# ddsperf prints per second "... mean X min Y 50% Z 90% ... 99% W max M", one-way (half the round
# trip), in microseconds.
python3 - "$work/ping.txt" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
p50 = [float(m) for m in re.findall(r" 50% ([0-9.]+)us", text)]
p99 = [float(m) for m in re.findall(r" 99% ([0-9.]+)us", text)]
if p50:
    p50.sort(); p99.sort()
    print("ddsperf ping/pong, one way: median over the seconds of p50 %.0f us and of p99 %.0f us; "
          "a round trip twice that" % (p50[len(p50) // 2], p99[len(p99) // 2]))
else:
    print("ddsperf: no result:\n" + text[-2000:])
PY
{
  echo "domain_id: 0"
  echo "plugin_directories: [$PWD/build/broken_plugins]"
  echo "log_level: warning"
} > "$work/locd.yaml"
run build/bin/locd --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
sleep 2
echo "locd_latency_probe (round trip through locd and a plugin worker):"
run build/bin/locd_latency_probe 0 "$((seconds * 200))" 5 | tail -1
