#!/usr/bin/env bash
# The cost of running plugins in worker processes, in one run: the same measurements against two
# builds, interleaved (server/README.md quotes the output):
#   - locd_latency_probe: 3000 odometry messages at 200 Hz through the fixture_odometry plugin
#     (a few microseconds of compute): publish -> pose p50 / p99;
#   - locsim live corridor, 20 s: scan published -> pose p50 / p99 and the part above the plugin;
#   - CPU of locd and its workers over the locsim run (user + system, children included), per
#     robot-second.
# Usage (as root, from the repository root):
#   bench/server/isolation_cost.sh BEFORE_BUILD_DIR AFTER_BUILD_DIR [ROUNDS]
# e.g. a worktree of the commit before the change, built into /work/wt-before/build.
set -euo pipefail
cd "$(dirname "$0")/../.."
before="$1"
after="$2"
rounds="${3:-3}"
source bench/lib/loopback_namespace.sh
field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p" "$2"; }

measure() {  # BUILD_DIR LABEL
  local build="$1" label="$2"
  cat > "$work/locd.yaml" <<EOF
domain_id: 91
plugin_directories: [$build/plugins, $build/broken_plugins]
map_directories: [$PWD/config/maps]
log_level: warning
EOF
  # Probe: its own server.
  run "$build/bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
  sleep 2  # loading the plugins on a busy machine
  local probe
  probe=$(run "$PWD/build/bin/locd_latency_probe" 91 3000 5 2>&1 | tail -2 | tr '\n' ' ' || true)
  pkill -TERM -f "$build/bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
  # Corridor, with the server's CPU (children included: bash's time reports wait4's rusage).
  local cpu_file="$work/cpu"
  ( TIMEFORMAT='%U %S'; { time run "$build/bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1; } 2> "$cpu_file" ) &
  sleep 2
  run "$build/bin/locsim" live config/scenarios/corridor.yaml --domain 91 --duration 20 --json > "$work/a.json" 2>/dev/null
  pkill -TERM -f "$build/bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
  read -r user sys < "$cpu_file"
  local cpu_ms
  cpu_ms=$(echo "($user + $sys) * 1000 / 20" | bc -l)
  printf "%-7s latency p50 %.3f ms p99 %.3f ms; above the plugin p50 %.3f ms p99 %.3f ms; server CPU %.1f ms per robot-second | probe: %s\n" \
    "$label" "$(field latency_ms_p50 "$work/a.json")" "$(field latency_ms_p99 "$work/a.json")" \
    "$(field overhead_ms_p50 "$work/a.json")" "$(field overhead_ms_p99 "$work/a.json")" "$cpu_ms" "$probe"
}

for round in $(seq "$rounds"); do
  measure "$before" before
  measure "$after" after
done
