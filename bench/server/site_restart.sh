#!/usr/bin/env bash
# A site restart, measured (README "Running the server" quotes it): one locd with a state file
# serves ROBOTS robots of `locsim fleet` (corridor_fleet: feature_ekf, odometry 20 Hz, scans
# 10 Hz); 15 s after every robot runs, locd is killed with SIGKILL and started again GAP_S seconds
# later, while the robots drive on. Per robot (locsim fleet --outage-report): how long after the
# restart its first pose came, that pose's position error, and the error 1 s and 5 s later.
# Usage (as root, from the repository root, after a build):
#   bench/server/site_restart.sh [GAP_S] [ROBOTS]
set -euo pipefail
cd "$(dirname "$0")/../.."
gap="${1:-1}"
robots="${2:-20}"
duration=$((gap + 40))
bin="$PWD/build/bin"
source bench/lib/loopback_namespace.sh

mkdir -p "$work/state"
cat > "$work/locd.yaml" <<EOF
domain_id: 91
plugin_directories: [$PWD/build/plugins]
map_directories: [$PWD/config/maps]
state_directory: $work/state
log_level: ${LOCD_LOG_LEVEL:-warning}
EOF
# locd's own pid (run() is a function: $! would be the shell that runs it).
locd_pid() { pgrep -f "^$bin/locd --config $work/locd.yaml" | head -1; }
run "$bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
sleep 0.5
run "$bin/locsim" fleet config/scenarios/corridor_fleet.yaml --robots "$robots" --duration "$duration" --domain 91 \
  --server-timeout 120 --json --outage-report > "$work/fleet.json" 2> "$work/fleet.err" &
fleet=$!
until grep -q "robots running" "$work/fleet.err"; do sleep 0.2; kill -0 "$fleet" || { cat "$work/fleet.err"; exit 1; }; done
sleep 15
kill -KILL "$(locd_pid)"
echo "locd killed (SIGKILL); started again ${gap} s later"
sleep "$gap"
[ -z "${LOCD_KEEP_LOGS:-}" ] || cp "$work/state/sessions.json" "$LOCD_KEEP_LOGS/sessions_at_the_kill.json"
restart_ns=$(date +%s%N)
run "$bin/locd" --config "$work/locd.yaml" > "$work/locd2.log" 2>&1 &
wait "$fleet" || true
python3 - "$work/fleet.json" "$restart_ns" <<'EOF'
import json, statistics, sys
r = json.load(open(sys.argv[1]))
restart_ns = int(sys.argv[2])
o = r["outage"]
served = [(t - restart_ns) * 1e-9 for t in o["served_again_wall_ns"] if t is not None]
def summary(values):
    values = [v for v in values if v is not None]
    return "median %.3f, max %.3f (%d robots)" % (statistics.median(values), max(values), len(values)) if values else "none"
print("robots served again after the restart: %d of %d" % (len(served), r["robots"]))
print("restart -> first pose, s: %s" % summary(served))
print("error of that first pose, m: %s" % summary(o["error_m_first"]))
print("error 1 s later, m: %s" % summary(o["error_m_1s_later"]))
print("error 5 s later, m: %s" % summary(o["error_m_5s_later"]))
print("poses duplicated: %d, robots silent at the end: %d" % (r["poses_duplicated"], r["robots_silent_at_end"]))
EOF
if [ -n "${LOCD_KEEP_LOGS:-}" ]; then cp "$work"/locd*.log "$work"/fleet.* "$LOCD_KEEP_LOGS"/ && echo "logs: $LOCD_KEEP_LOGS"; fi
kill -TERM "$(locd_pid)" 2>/dev/null || true
wait 2>/dev/null || true
