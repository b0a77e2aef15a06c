#!/usr/bin/env bash
# Capacity of one server, measured (README quotes the output): locd pinned to core 0 (its
# plugin workers with it), locsim fleet pinned to core 1, N feature_ekf robots of
# config/scenarios/corridor_fleet.yaml (odometry 20 Hz, 361-beam scans 10 Hz) for each N given.
# Per N: poses per second, poses missing, latency p50/p99, the server's CPU per robot-second and
# memory, lost / dropped. A server "keeps up" at N when no pose is missing, nothing is lost or
# dropped, and p99 <= 20 ms. Loopback only, in a network namespace made here.
# Usage (as root, from the repository root):
#   bench/fleet/capacity.sh DURATION_S SESSIONS_PER_WORKER|- N...
# LOCD_BIN / LOCD_PLUGINS / LOCD_GENERATOR: another build's locd, plugins and locsim;
# LOCD_SCENARIO: another scenario (e.g. config/scenarios/ceiling_hall.yaml); LOCD_DISTINCT: runs.
set -euo pipefail
cd "$(dirname "$0")/../.."
duration="$1"; shift
per_worker="$1"; shift
bin="${LOCD_BIN:-$PWD/build/bin}"
plugins="${LOCD_PLUGINS:-$PWD/build/plugins}"
source bench/lib/loopback_namespace.sh
{
  echo "domain_id: 2"
  echo "plugin_directories: [$plugins]"
  echo "map_directories: [$PWD/config/maps]"
  echo "max_sessions: 100000"
  echo "log_level: warning"
  # "-": a build from before plugin workers (issue 10), which has no such key
  [ "$per_worker" = "-" ] || echo "plugin_workers: {sessions_per_worker: $per_worker}"
} > "$work/locd.yaml"
cat > "$work/summary.py" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except Exception:
    print("N=%s: no result" % sys.argv[2]); sys.exit(0)
keeps = (r["poses_missing"] == 0 and r["server_lost_in_transit"] == 0 and r["server_dropped"] == 0
         and r["latency_ms_p99"] <= 20)
print("N=%5d poses/s %7.0f missing %6d lost %6d dropped %6d latency p50 %6.2f p99 %8.2f ms  CPU %5.1f %% = %.3f ms "
      "per robot-s  memory %.0f MB (%.2f MB/session, %d processes)  generator lag p99 %.1f ms  %s" % (
      r["robots"], r["poses_per_s"], r["poses_missing"], r["server_lost_in_transit"], r["server_dropped"],
      r["latency_ms_p50"], r["latency_ms_p99"], r.get("server_cpu_percent", 0), r.get("server_cpu_ms_per_robot_s", 0),
      r.get("server_memory_mb", 0), r.get("server_memory_mb_per_session", 0), r.get("server_processes", 0),
      r["generator_lag_ms_p99"], "keeps up" if keeps else "DOES NOT keep up"))
PY
for n in "$@"; do
  run taskset -c 0 "$bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
  sleep 2
  pid=$(pgrep -f "locd --config $work/locd.yaml" | head -1)
  run taskset -c 1 "${LOCD_GENERATOR:-$PWD/build/bin/locsim}" fleet "${LOCD_SCENARIO:-config/scenarios/corridor_fleet.yaml}" \
    --robots "$n" --distinct "${LOCD_DISTINCT:-8}" \
    --duration "$duration" --domain 2 --server-pid "$pid" --server-timeout 300 --json \
    > "$work/out.json" 2> "$work/err.txt" || true
  python3 "$work/summary.py" "$work/out.json" "$n"
  kill -TERM "$pid" 2>/dev/null || true
  wait 2>/dev/null || true
done
