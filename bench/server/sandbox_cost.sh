#!/usr/bin/env bash
# The cost of the worker sandbox (Landlock, seccomp, no capabilities), in one run of one build:
# the same measurements with `plugin_workers: {sandbox: true}` and `{sandbox: false}`, interleaved
# (README "Plugins are not trusted" quotes the output):
#   - locd_latency_probe: 3000 odometry messages at 200 Hz through fixture_odometry: publish -> pose p50 / p99;
#   - locsim live corridor (feature_ekf), 20 s: scan published -> pose p50 / p99, and the CPU of
#     locd and its workers (user + system, children included) per robot-second.
# Usage (as root, from the repository root): bench/server/sandbox_cost.sh [ROUNDS]
set -euo pipefail
cd "$(dirname "$0")/../.."
build="$PWD/build"
rounds="${1:-1}"
source bench/lib/loopback_namespace.sh
field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p" "$2"; }

measure() {  # true|false
  local sandbox="$1"
  cat > "$work/locd.yaml" <<EOF
domain_id: 92
plugin_directories: [$build/plugins, $build/broken_plugins]
map_directories: [$PWD/config/maps]
log_level: warning
plugin_workers: {sandbox: $sandbox}
EOF
  run "$build/bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1 &
  sleep 2
  local probe
  probe=$(run "$build/bin/locd_latency_probe" 92 3000 5 2>&1 | tail -2 | tr '\n' ' ' || true)
  pkill -TERM -f "$build/bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
  local cpu_file="$work/cpu"
  ( TIMEFORMAT='%U %S'; { time run "$build/bin/locd" --config "$work/locd.yaml" > "$work/locd.log" 2>&1; } 2> "$cpu_file" ) &
  sleep 2
  run "$build/bin/locsim" live config/scenarios/corridor.yaml --domain 92 --duration 20 --json > "$work/a.json" 2>/dev/null
  pkill -TERM -f "$build/bin/locd --config $work/locd.yaml" || true
  wait 2>/dev/null || true
  read -r user sys < "$cpu_file"
  local cpu_ms
  cpu_ms=$(echo "($user + $sys) * 1000 / 20" | bc -l)
  printf "sandbox %-5s corridor latency p50 %.3f ms p99 %.3f ms; server CPU %.1f ms per robot-second | probe: %s\n" \
    "$sandbox" "$(field latency_ms_p50 "$work/a.json")" "$(field latency_ms_p99 "$work/a.json")" "$cpu_ms" "$probe"
}

for round in $(seq "$rounds"); do
  measure true
  measure false
done
