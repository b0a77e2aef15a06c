#!/usr/bin/env bash
# Takeover, measured (README quotes the output): three locd servers on three hosts and N robots
# of `locsim fleet` on a fourth (network namespaces joined by a bridge, tests/common/hosts.sh;
# nothing leaves them), one server killed with kill -9 (or its cable cut) in the middle of the
# run. Prints the spread of the robots over the servers before and after, the longest wait of
# any robot between two poses, the poses missing, and locsim fleet's whole JSON.
# Usage (as root, from the repository root, after a build):
#   bench/fleet/takeover.sh [ROBOTS] [DURATION_S] [kill|cut]
set -euo pipefail
cd "$(dirname "$0")/../.."
robots="${1:-600}"
duration="${2:-40}"
how="${3:-kill}"
prefix="lt$$"
work="$(mktemp -d)"
bin="$PWD/build/bin"
tests/common/hosts.sh up "$prefix" 4 "$work"
cleanup() { tests/common/hosts.sh down "$prefix" 4; rm -rf "$work"; }
trap cleanup EXIT
on() { local host=$1; shift; ip netns exec "$prefix$host" env CYCLONEDDS_URI="file://$work/host$host.xml" "$@"; }

for s in 1 2 3; do
  cat > "$work/locd$s.yaml" <<EOF
server_id: server$s
domain_id: 1
plugin_directories: [$PWD/build/plugins]
map_directories: [$PWD/config/maps]
max_sessions: 10000
log_level: warning
plugin_workers: {sessions_per_worker: 50}
EOF
  on "$s" "$bin/locd" --config "$work/locd$s.yaml" > "$work/locd$s.log" 2>&1 &
done
sleep 3
on 0 "$bin/locsim" fleet config/scenarios/corridor_fleet.yaml --robots "$robots" --duration "$duration" --domain 1 \
  --server-timeout 120 --json --plot "$work/takeover.png" > "$work/fleet.json" 2> "$work/fleet.err" &
fleet=$!
until grep -q "robots running" "$work/fleet.err"; do sleep 0.2; kill -0 "$fleet" || { cat "$work/fleet.err"; exit 1; }; done
sleep $((duration / 2))
echo "before: $(on 0 "$bin/locctl" status --domain 1 --json | python3 -c 'import json,sys,collections; print(dict(collections.Counter(s["server"] for s in json.load(sys.stdin)["sessions"])))')"
if [ "$how" = cut ]; then
  tests/common/hosts.sh cut "$prefix" 2
  echo "server2's cable cut at $(date +%T.%N)"
else
  pkill -9 -f "locd --config $work/locd2.yaml"
  echo "server2 killed (SIGKILL) at $(date +%T.%N)"
fi
wait "$fleet" || true
echo "after: $(on 0 "$bin/locctl" status --domain 1 --json | python3 -c 'import json,sys,collections; print(dict(collections.Counter(s["server"] for s in json.load(sys.stdin)["sessions"])))')"
python3 - "$work/fleet.json" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
print("robots %d, longest wait between two poses of any robot %.0f ms, poses missing %d of %d, silent at the end %d, "
      "latency p50 %.2f ms p99 %.2f ms" % (r["robots"], r["max_pose_gap_ms"], r["poses_missing"], r["poses_expected"],
      r["robots_silent_at_end"], r["latency_ms_p50"], r["latency_ms_p99"]))
print(json.dumps(r))
EOF
cp "$work/takeover.png" /tmp/takeover.png 2>/dev/null && echo "plot: /tmp/takeover.png"
for s in 1 3; do pkill -TERM -f "locd --config $work/locd$s.yaml" || true; done
wait 2>/dev/null || true
